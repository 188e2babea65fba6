// Rasterizer forward (tiled, watertight, deterministic depth test) and its
// adjoint (per-pixel contributions scattered in pixel order).
//
// Forward: project vertices; classify triangles in parallel (frustum reject,
// area, culling, pixel bounding box) and bin them to kTile x kTile screen
// tiles, in parallel over fixed triangle chunks (counts per chunk and tile,
// offsets chunk by chunk within each tile, then a fill per chunk), so every
// tile lists its triangles in ascending order for any thread count; then
// parallel_for over non-empty tiles, each owning its pixels, so the
// (depth, id) test needs no atomics and is order independent.
#include "raster/rasterize.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "autodiff/error.h"
#include "autodiff/parallel.h"
#include "raster/guarded_math.h"
#include "raster/project.h"
#include "raster/rasterize_setup.h"

namespace gr::raster {
namespace {

using detail::finite_cast;
using detail::safe_inv;

constexpr int kTile = 32;

// Triangles listed per tile, in triangle order.
struct Bins {
  int tiles_x = 0, tiles_y = 0;
  std::vector<std::int64_t> offset;  // tiles + 1
  // Left uninitialized on allocation (every entry is written before use), so
  // first-touch page faults happen in the parallel passes, not in a serial fill.
  std::unique_ptr<std::int32_t[]> tris;
  std::unique_ptr<detail::PixelBox[]> box;  // per triangle
};

// Triangles per binning chunk: a function of the triangle and tile counts only
// (never of the thread count): at least 4096, at most 256 chunks, and at most
// ~2M (chunk, tile) counters.
std::int64_t bin_chunk(std::int64_t num_tris, int tiles) {
  constexpr std::int64_t kMinChunk = 4096, kMaxChunks = 256, kMaxCounters = std::int64_t(1) << 21;
  const std::int64_t max_chunks = std::max<std::int64_t>(1, std::min(kMaxChunks, kMaxCounters / tiles));
  return std::max(kMinChunk, (num_tris + max_chunks - 1) / max_chunks);
}

// Scans one tile: every binned triangle over its box clipped to the tile.
void scan_tile(const detail::Vertices& v, const std::int32_t* tris, const Bins& bins, int tile,
               int width, int height, double* zbuf, std::int32_t* ids, double* lu, double* lv) {
  const int tx0 = (tile % bins.tiles_x) * kTile, ty0 = (tile / bins.tiles_x) * kTile;
  const int tx1 = std::min(tx0 + kTile, width) - 1, ty1 = std::min(ty0 + kTile, height) - 1;
  std::fill(zbuf, zbuf + kTile * kTile, std::numeric_limits<double>::infinity());
  std::fill(ids, ids + kTile * kTile, -1);
  for (std::int64_t n = bins.offset[tile]; n < bins.offset[tile + 1]; ++n) {
    const std::int32_t t = bins.tris[n];
    const detail::PixelBox& b = bins.box[t];
    const int x0 = std::max(b.x0, tx0), x1 = std::min(b.x1, tx1);
    const int y0 = std::max(b.y0, ty0), y1 = std::min(b.y1, ty1);
    detail::TriSetup s;
    detail::setup_edges(v, tris + 3 * static_cast<std::int64_t>(t), width, height, &s);
    const detail::Edge &e0 = s.e[0], &e1 = s.e[1], &e2 = s.e[2];
    for (int y = y0; y <= y1; ++y) {
      const double py = y + 0.5;
      const double r0 = e0.row(py), r1 = e1.row(py), r2 = e2.row(py);
      const int row = (y - ty0) * kTile - tx0;
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5;
        // Coverage: all three edges inside (ties by the top-left rule).
        const double v0 = e0.eval(px, r0), v1 = e1.eval(px, r1), v2 = e2.eval(px, r2);
        if (!(e0.inside(v0) && e1.inside(v1) && e2.inside(v2))) continue;
        // Depth, near/far test, then the (depth, id) key test.
        const double z = v0 * e0.mz + v1 * e1.mz + v2 * e2.mz;
        if (s.z_test && !(z >= -1.0 && z <= 1.0)) continue;
        const int p = row + x;
        if (z < zbuf[p] || (z == zbuf[p] && t < ids[p])) {
          zbuf[p] = z;
          ids[p] = t;
          lu[p] = v1 * e1.mu;
          lv[p] = v2 * e2.mu;
        }
      }
    }
  }
}

}  // namespace

template <class T>
void rasterize_forward(const T* clip, std::int64_t num_vertices, const std::int32_t* tris,
                       std::int64_t num_tris, const RasterSettings& s, std::int32_t* tri_id,
                       T* uv, T* depth, RasterStats* stats) {
  const char* op = "rasterize";
  // Validate before allocating anything.
  detail::check_image_size(s.width, s.height, op);
  detail::check_triangles(tris, num_tris, num_vertices, op);
  detail::check_finite(clip, 4 * num_vertices, "clip", op);
  const int W = s.width, H = s.height;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;

  // Background everywhere; tiles overwrite covered pixels.
  parallel_for(0, P, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t p = lo; p < hi; ++p) {
      tri_id[p] = 0;
      uv[2 * p] = uv[2 * p + 1] = T(0);
      depth[p] = T(kBackgroundDepth);
    }
  });

  // Per-vertex projection, then per-triangle classification and binning.
  const detail::Vertices v = detail::project_vertices(clip, num_vertices, W, H);
  const int cull = s.cull == Cull::Back ? 1 : s.cull == Cull::Front ? -1 : 0;
  Bins bins;
  bins.box.reset(new detail::PixelBox[static_cast<std::size_t>(num_tris)]);
  bins.tiles_x = (W + kTile - 1) / kTile;
  bins.tiles_y = (H + kTile - 1) / kTile;
  const int tiles = bins.tiles_x * bins.tiles_y;
  const std::int64_t chunk = bin_chunk(num_tris, tiles);
  const std::int64_t chunks = (num_tris + chunk - 1) / chunk;
  std::vector<detail::TriClass> cls(num_tris);

  // Pass 1 (parallel over fixed triangle chunks): classify, and count each
  // chunk's triangles per tile. Chunks depend on num_tris and tiles only.
  std::vector<std::int64_t> at(static_cast<std::size_t>(chunks) * tiles, 0);  // counts, then cursors
  std::vector<RasterStats> cst(static_cast<std::size_t>(chunks));
  parallel_for(0, chunks, 1, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      std::int64_t* cnt = &at[static_cast<std::size_t>(c) * tiles];
      RasterStats& st = cst[c];
      const std::int64_t t1 = std::min(num_tris, (c + 1) * chunk);
      for (std::int64_t t = c * chunk; t < t1; ++t) {
        const detail::TriClass k = cls[t] =
            detail::classify_triangle(v, tris + 3 * t, W, H, cull, &bins.box[t]);
        switch (k) {
          case detail::TriClass::Outside: ++st.culled_outside; continue;
          case detail::TriClass::ZeroArea: ++st.culled_zero_area; continue;
          case detail::TriClass::Face: ++st.culled_face; continue;
          case detail::TriClass::NoPixel: ++st.culled_no_pixel; continue;
          case detail::TriClass::Clipped: ++st.clipped_near; break;
          case detail::TriClass::Raster: ++st.rasterized; break;
        }
        const detail::PixelBox& b = bins.box[t];
        for (int ty = b.y0 / kTile; ty <= b.y1 / kTile; ++ty)
          for (int tx = b.x0 / kTile; tx <= b.x1 / kTile; ++tx) ++cnt[ty * bins.tiles_x + tx];
      }
    }
  });
  RasterStats st;
  st.triangles_in = num_tris;
  for (const RasterStats& c : cst) {
    st.culled_outside += c.culled_outside;
    st.culled_zero_area += c.culled_zero_area;
    st.culled_face += c.culled_face;
    st.culled_no_pixel += c.culled_no_pixel;
    st.clipped_near += c.clipped_near;
    st.rasterized += c.rasterized;
  }

  // Offsets tile by tile, chunks in order within a tile: each tile's list is
  // in ascending triangle order. Counts become each (chunk, tile) cursor.
  bins.offset.assign(tiles + 1, 0);
  {
    std::int64_t run = 0;
    for (int i = 0; i < tiles; ++i) {
      bins.offset[i] = run;
      for (std::int64_t c = 0; c < chunks; ++c) {
        std::int64_t& a = at[static_cast<std::size_t>(c) * tiles + i];
        const std::int64_t n = a;
        a = run;
        run += n;
      }
    }
    bins.offset[tiles] = run;
  }
  bins.tris.reset(new std::int32_t[static_cast<std::size_t>(bins.offset[tiles])]);

  // Pass 2 (parallel over the same chunks): fill, each chunk into its own slots.
  parallel_for(0, chunks, 1, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      std::int64_t* fill = &at[static_cast<std::size_t>(c) * tiles];
      const std::int64_t t1 = std::min(num_tris, (c + 1) * chunk);
      for (std::int64_t t = c * chunk; t < t1; ++t) {
        if (cls[t] != detail::TriClass::Raster && cls[t] != detail::TriClass::Clipped) continue;
        const detail::PixelBox& b = bins.box[t];
        for (int ty = b.y0 / kTile; ty <= b.y1 / kTile; ++ty)
          for (int tx = b.x0 / kTile; tx <= b.x1 / kTile; ++tx)
            bins.tris[fill[ty * bins.tiles_x + tx]++] = static_cast<std::int32_t>(t);
      }
    }
  });
  if (stats) *stats = st;

  // Scan the non-empty tiles in parallel; each writes only its own pixels.
  std::vector<int> busy;
  for (int i = 0; i < tiles; ++i)
    if (bins.offset[i + 1] > bins.offset[i]) busy.push_back(i);
  parallel_for(0, static_cast<std::int64_t>(busy.size()), 1, [&](std::int64_t lo, std::int64_t hi) {
    std::vector<double> zbuf(kTile * kTile), lu(kTile * kTile), lv(kTile * kTile);
    std::vector<std::int32_t> ids(kTile * kTile);
    for (std::int64_t n = lo; n < hi; ++n) {
      const int tile = busy[n];
      scan_tile(v, tris, bins, tile, W, H, zbuf.data(), ids.data(), lu.data(), lv.data());
      // Copy the tile's covered pixels out.
      const int tx0 = (tile % bins.tiles_x) * kTile, ty0 = (tile / bins.tiles_x) * kTile;
      const int tw = std::min(kTile, W - tx0), th = std::min(kTile, H - ty0);
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) {
          const int q = y * kTile + x;
          if (ids[q] < 0) continue;
          const std::int64_t p = static_cast<std::int64_t>(ty0 + y) * W + tx0 + x;
          tri_id[p] = ids[q] + 1;
          uv[2 * p] = static_cast<T>(lu[q]);
          uv[2 * p + 1] = static_cast<T>(lv[q]);
          depth[p] = static_cast<T>(zbuf[q]);
        }
    }
  });
}

namespace {

// Gradient of the screen-space triangle functions at one pixel: the adjoint of
//   u = E_20/2A, v = E_01/2A, depth = (1-u-v) z0 + u z1 + v z2
// w.r.t. the screen positions (x_k, y_k) and z_k = z_ndc; out[3k..3k+2].
void pixel_grad_screen(const double* p0, const double* p1, const double* p2, double px, double py,
                       double gu, double gv, double gd, double* out) {
  // Edge function E(q; a, b) and its partials w.r.t. a and b (accumulated).
  auto edge = [](double qx, double qy, const double* a, const double* b) {
    return (qx - a[0]) * (b[1] - a[1]) - (qy - a[1]) * (b[0] - a[0]);
  };
  auto edge_grad = [](double qx, double qy, const double* a, const double* b, double g, double* ga,
                      double* gb) {
    ga[0] += g * (qy - b[1]);
    ga[1] += g * (b[0] - qx);
    gb[0] += g * (a[1] - qy);
    gb[1] += g * (qx - a[0]);
  };
  const double a2 = edge(p0[0], p0[1], p1, p2);
  const double inv = safe_inv(a2);
  const double u = edge(px, py, p2, p0) * inv, v = edge(px, py, p0, p1) * inv;
  // Depth reaches u and v too.
  const double gu2 = gu + gd * (p1[2] - p0[2]), gv2 = gv + gd * (p2[2] - p0[2]);
  // Quotient rule on u = E_20/2A, v = E_01/2A.
  const double g20 = gu2 * inv, g01 = gv2 * inv, ga2 = -(gu2 * u + gv2 * v) * inv;
  double* g0 = out;
  double* g1 = out + 3;
  double* g2 = out + 6;
  edge_grad(px, py, p2, p0, g20, g2, g0);
  edge_grad(px, py, p0, p1, g01, g0, g1);
  // 2A = E(p0; p1, p2) also depends on p0 as the query point: dE/dq = (by-ay, ax-bx).
  edge_grad(p0[0], p0[1], p1, p2, ga2, g1, g2);
  g0[0] += ga2 * (p2[1] - p1[1]);
  g0[1] += ga2 * (p1[0] - p2[0]);
  // Depth w.r.t. z_ndc: the barycentric weights.
  g0[2] += gd * (1.0 - u - v);
  g1[2] += gd * u;
  g2[2] += gd * v;
}

// Same function in homogeneous form (any vertex behind the near plane):
//   u = w1 F1/D, v = w2 F2/D, depth = sum z_k F_k/D, F_k = s.(V_a x V_b), D = V0.(V1 x V2),
// V = (W/2 (x+w), H/2 (w-y), w); gradient w.r.t. clip (x, y, z, w), out[4k..4k+3].
void pixel_grad_homogeneous(const detail::Vertices& vx, const std::int32_t* tri, int width,
                            int height, double px, double py, double gu, double gv, double gd,
                            double* out) {
  using detail::HVec;
  const HVec V[3] = {detail::homogeneous(vx, tri[0], width, height),
                     detail::homogeneous(vx, tri[1], width, height),
                     detail::homogeneous(vx, tri[2], width, height)};
  const HVec s{px, py, 1.0};
  double w[3], z[3], F[3];
  for (int k = 0; k < 3; ++k) {
    w[k] = V[k].w;
    z[k] = vx.clip[4 * static_cast<std::size_t>(tri[k]) + 2];
    F[k] = dot(s, detail::cross(V[(k + 1) % 3], V[(k + 2) % 3]));
  }
  const double D = dot(V[0], detail::cross(V[1], V[2]));
  const double inv = safe_inv(D);
  const double u = w[1] * F[1] * inv, v = w[2] * F[2] * inv;
  const double depth = (z[0] * F[0] + z[1] * F[1] + z[2] * F[2]) * inv;
  // Adjoints of F_k and D.
  double gF[3];
  for (int k = 0; k < 3; ++k) gF[k] = gd * z[k] * inv;
  gF[1] += gu * w[1] * inv;
  gF[2] += gv * w[2] * inv;
  const double gD = -(gu * u + gv * v + gd * depth) * inv;
  // Back to the homogeneous vertices: dF_k/dV_a = V_b x s, dF_k/dV_b = s x V_a,
  // dD/dV_k = V_k+1 x V_k+2.
  HVec gV[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  auto add = [](HVec& acc, const HVec& d, double g) {
    acc.x += g * d.x;
    acc.y += g * d.y;
    acc.w += g * d.w;
  };
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    add(gV[a], detail::cross(V[b], s), gF[k]);
    add(gV[b], detail::cross(s, V[a]), gF[k]);
    add(gV[k], detail::cross(V[a], V[b]), gD);
  }
  // Direct dependences on w_1, w_2 (through u, v) and z_k (through depth).
  gV[1].w += gu * F[1] * inv;
  gV[2].w += gv * F[2] * inv;
  // V = (W/2 (x+w), H/2 (w-y), w) -> clip.
  const double hw = 0.5 * width, hh = 0.5 * height;
  for (int k = 0; k < 3; ++k) {
    double* o = out + 4 * k;
    o[0] += hw * gV[k].x;
    o[1] -= hh * gV[k].y;
    o[2] += gd * F[k] * inv;
    o[3] += hw * gV[k].x + hh * gV[k].y + gV[k].w;
  }
}

}  // namespace

template <class T>
void rasterize_backward(const T* clip, std::int64_t num_vertices, const std::int32_t* tris,
                        std::int64_t num_tris, const RasterSettings& s, const std::int32_t* tri_id,
                        const T* grad_uv, const typename detail::NoDeduce<T>::type* grad_depth,
                        T* grad_clip) {
  const char* op = "rasterize backward";
  detail::check_image_size(s.width, s.height, op);
  detail::check_triangles(tris, num_tris, num_vertices, op);
  detail::check_finite(clip, 4 * num_vertices, "clip", op);
  const int W = s.width, H = s.height;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;
  detail::check_tri_ids(tri_id, P, num_tris, op);
  const detail::Vertices v = detail::project_vertices(clip, num_vertices, W, H);

  // Per-vertex accumulators: screen (x, y, z_ndc) and clip (x, y, z, w).
  std::vector<double> acc_screen(3 * num_vertices, 0.0);
  std::vector<double> acc_clip;
  bool any_screen = false;

  // Pixels in chunks: contributions in parallel, then added in pixel order.
  constexpr std::int64_t kChunk = 16384;
  std::vector<double> contrib(12 * kChunk);
  std::vector<std::int8_t> kind(kChunk);  // 0 none, 1 screen, 2 homogeneous
  for (std::int64_t c0 = 0; c0 < P; c0 += kChunk) {
    const std::int64_t c1 = std::min(P, c0 + kChunk);
    parallel_for(c0, c1, 1024, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t p = lo; p < hi; ++p) {
        std::int8_t& k = kind[p - c0];
        k = 0;
        const std::int32_t id = tri_id[p];
        if (id == 0) continue;
        const double gu = grad_uv[2 * p], gv = grad_uv[2 * p + 1];
        const double gd = grad_depth ? static_cast<double>(grad_depth[p]) : 0.0;
        // Zero incoming gradient: skip.
        if (gu == 0.0 && gv == 0.0 && gd == 0.0) continue;
        const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(id - 1);
        const double px = static_cast<double>(p % W) + 0.5, py = static_cast<double>(p / W) + 0.5;
        double* out = &contrib[12 * (p - c0)];
        std::fill(out, out + 12, 0.0);
        if (!detail::needs_clipping(v, tri)) {
          pixel_grad_screen(&v.screen[3 * static_cast<std::size_t>(tri[0])],
                            &v.screen[3 * static_cast<std::size_t>(tri[1])],
                            &v.screen[3 * static_cast<std::size_t>(tri[2])], px, py, gu, gv, gd, out);
          k = 1;
        } else {
          pixel_grad_homogeneous(v, tri, W, H, px, py, gu, gv, gd, out);
          k = 2;
        }
      }
    });
    // Scatter in pixel order (deterministic for any thread count / triangle order).
    for (std::int64_t p = c0; p < c1; ++p) {
      const std::int8_t k = kind[p - c0];
      if (k == 0) continue;
      const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
      const double* g = &contrib[12 * (p - c0)];
      if (k == 1) {
        any_screen = true;
        for (int j = 0; j < 3; ++j)
          for (int d = 0; d < 3; ++d) acc_screen[3 * static_cast<std::size_t>(tri[j]) + d] += g[3 * j + d];
      } else {
        if (acc_clip.empty()) acc_clip.assign(4 * num_vertices, 0.0);
        for (int j = 0; j < 3; ++j)
          for (int d = 0; d < 4; ++d) acc_clip[4 * static_cast<std::size_t>(tri[j]) + d] += g[4 * j + d];
      }
    }
  }

  // Screen -> NDC -> clip per vertex with the projection adjoints.
  if (any_screen) {
    std::vector<T> g_screen(2 * num_vertices), g_ndc(3 * num_vertices, T(0));
    parallel_for(0, num_vertices, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t i = lo; i < hi; ++i) {
        g_screen[2 * i] = finite_cast<T>(acc_screen[3 * i]);
        g_screen[2 * i + 1] = finite_cast<T>(acc_screen[3 * i + 1]);
        g_ndc[3 * i + 2] = finite_cast<T>(acc_screen[3 * i + 2]);
      }
    });
    viewport_backward(num_vertices, W, H, g_screen.data(), g_ndc.data());
    // Only vertices of screen-form triangles (w > 0) carry gradient here.
    wdivide_backward(clip, num_vertices, g_ndc.data(), grad_clip);
  }
  if (!acc_clip.empty())
    parallel_for(0, 4 * num_vertices, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t i = lo; i < hi; ++i) grad_clip[i] += finite_cast<T>(acc_clip[i]);
    });
}

#define GR_INSTANTIATE(T)                                                                         \
  template void rasterize_forward<T>(const T*, std::int64_t, const std::int32_t*, std::int64_t,  \
                                     const RasterSettings&, std::int32_t*, T*, T*, RasterStats*); \
  template void rasterize_backward<T>(const T*, std::int64_t, const std::int32_t*, std::int64_t, \
                                      const RasterSettings&, const std::int32_t*, const T*,       \
                                      const T*, T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
