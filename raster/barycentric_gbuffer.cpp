// nvdiffrast-layout G-buffer from a coverage image, and its adjoint
// (formulas in barycentric_gbuffer.h). Per pixel everything is evaluated in
// double from the three homogeneous screen vertices; the adjoint scatters by
// gathering (docs/determinism.md): pixels grouped by triangle, each
// triangle's terms computed once and its pixels' contributions summed per
// corner in pixel order, then each vertex's corners in a fixed order.
#include "raster/barycentric_gbuffer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/buckets.h"
#include "raster/detail/corner_gather.h"
#include "raster/detail/guarded_math.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/triangle_groups.h"

namespace gr::raster {
namespace {

using detail::cross;
using detail::finite_cast;
using detail::dot;
using detail::HVec;

// The homogeneous quantities of one triangle (the same for all its pixels,
// so consecutive pixels of one triangle compute them once).
struct TriangleTerms {
  HVec V[3], c[3], C;
  double D, z[3];
};

template <class T>
TriangleTerms triangle_terms(const BarycentricGBufferParams<T>& p, std::int64_t tri) {
  TriangleTerms t;
  const std::int32_t* idx = p.tris + 3 * tri;
  const double hw = 0.5 * p.width, hh = 0.5 * p.height;
  for (int k = 0; k < 3; ++k) {
    const T* v = p.clip + 4 * static_cast<std::int64_t>(idx[k]);
    const double x = v[0], y = detail::seen_y(v[1], p.y_up), w = v[3];
    t.V[k] = {hw * (x + w), hh * (w - y), w};
    t.z[k] = v[2];
  }
  t.C = {0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) {
    t.c[k] = cross(t.V[(k + 1) % 3], t.V[(k + 2) % 3]);
    t.C = {t.C.x + t.c[k].x, t.C.y + t.c[k].y, t.C.w + t.c[k].w};
  }
  t.D = dot(t.V[0], t.c[0]);
  return t;
}

// The per-pixel quantities: a_k = e . c_k and S = sum a_k.
struct PixelTerms {
  double a[3], S;
  bool valid;  // S and D nonzero and finite
};

PixelTerms pixel_terms(const TriangleTerms& t, int width, std::int64_t pixel) {
  PixelTerms q;
  const HVec e{static_cast<double>(pixel % width) + 0.5, static_cast<double>(pixel / width) + 0.5, 1.0};
  q.S = 0.0;
  for (int k = 0; k < 3; ++k) {
    q.a[k] = dot(e, t.c[k]);
    q.S += q.a[k];
  }
  q.valid = q.S != 0.0 && t.D != 0.0 && std::isfinite(q.S) && std::isfinite(t.D);
  return q;
}

// The adjoint's coverage: pixel q's 1-based id (0 = background).
template <class T>
std::int64_t pixel_id(const BarycentricGBufferParams<T>& p, const T* rast, std::int64_t q) {
  return p.tri_id ? static_cast<std::int64_t>(p.tri_id[q]) : static_cast<std::int64_t>(rast[4 * q + 3]);
}

// dL/dclip of the three vertices (12 values) for one pixel.
template <class T>
void pixel_adjoint(const BarycentricGBufferParams<T>& p, const TriangleTerms& t, std::int64_t pixel, const T* g_rast,
                   const T* g_db, double* out) {
  const PixelTerms q = pixel_terms(t, p.width, pixel);
  std::fill(out, out + 12, 0.0);
  if (!q.valid) return;
  const double S = q.S, D = t.D;
  const double* const a = q.a;
  const double b[2] = {a[0] / S, a[1] / S};
  const double g[3] = {static_cast<double>(g_rast[0]), static_cast<double>(g_rast[1]), 0.0};
  const double gz = g_rast[2];
  const double* const z = t.z;
  double zw = 0.0;
  for (int k = 0; k < 3; ++k) zw += a[k] * z[k];
  zw /= D;
  // b_k = a_k / S and z/w = sum a_k z_k / D.
  const double gb = g[0] * b[0] + g[1] * b[1];
  double bar_a[3], bar_z[3];
  for (int k = 0; k < 3; ++k) {
    bar_a[k] = (g[k] - gb) / S + gz * z[k] / D;
    bar_z[k] = gz * a[k] / D;
  }
  const double bar_D = -gz * zw / D;
  // db_k/dd = c_k.d / S - a_k C.d / S^2 for d in {x, y}.
  HVec bar_c[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  HVec bar_C{0, 0, 0};
  double bar_S = 0.0;
  if (g_db) {
    const double S2 = S * S;
    for (int k = 0; k < 2; ++k) {
      const double hx = g_db[2 * k], hy = g_db[2 * k + 1];
      bar_c[k].x += hx / S;
      bar_c[k].y += hy / S;
      bar_C.x -= hx * a[k] / S2;
      bar_C.y -= hy * a[k] / S2;
      bar_a[k] -= (hx * t.C.x + hy * t.C.y) / S2;
      bar_S += (2.0 * a[k] * (hx * t.C.x + hy * t.C.y) / S - (hx * t.c[k].x + hy * t.c[k].y)) / S2;
    }
  }
  const double ex = static_cast<double>(pixel % p.width) + 0.5, ey = static_cast<double>(pixel / p.width) + 0.5;
  HVec bar_V[3];
  for (int k = 0; k < 3; ++k) {
    const double ba = bar_a[k] + bar_S;  // S = sum a_k
    // a_k = e . c_k, C = sum c_k.
    bar_c[k] = {bar_c[k].x + ba * ex + bar_C.x, bar_c[k].y + ba * ey + bar_C.y, bar_c[k].w + ba + bar_C.w};
    bar_V[k] = {bar_D * t.c[k].x, bar_D * t.c[k].y, bar_D * t.c[k].w};  // dD/dV_k = c_k
  }
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    const HVec d1 = cross(t.V[k2], bar_c[k]), d2 = cross(bar_c[k], t.V[k1]);
    bar_V[k1] = {bar_V[k1].x + d1.x, bar_V[k1].y + d1.y, bar_V[k1].w + d1.w};
    bar_V[k2] = {bar_V[k2].x + d2.x, bar_V[k2].y + d2.y, bar_V[k2].w + d2.w};
  }
  // V = (W/2 (x + w), H/2 (w - y), w) -> clip; with y_up V holds -y, so
  // dL/dy = +H/2 dL/dV.y (the negation of -H/2 dL/dV.y, exact).
  const double hw = 0.5 * p.width, hh = 0.5 * p.height, hy = p.y_up ? hh : -hh;
  for (int k = 0; k < 3; ++k) {
    double* o = out + 4 * k;
    o[0] = hw * bar_V[k].x;
    o[1] = hy * bar_V[k].y;
    o[2] = bar_z[k];
    o[3] = hw * bar_V[k].x + hh * bar_V[k].y + bar_V[k].w;
  }
}

}  // namespace

namespace {

// What the forward reads of a triangle's terms (TriangleTerms without V and
// C.w), computed with triangle_terms' arithmetic in the same order, so the
// same bits.
struct ForwardTerms {
  HVec c[3];
  double Cx, Cy, D, z[3];
};

template <class T>
ForwardTerms forward_terms(const BarycentricGBufferParams<T>& p, std::int64_t tri) {
  ForwardTerms t;
  const std::int32_t* idx = p.tris + 3 * tri;
  const double hw = 0.5 * p.width, hh = 0.5 * p.height;
  HVec V[3];
  for (int k = 0; k < 3; ++k) {
    const T* v = p.clip + 4 * static_cast<std::int64_t>(idx[k]);
    const double x = v[0], y = detail::seen_y(v[1], p.y_up), w = v[3];
    V[k] = {hw * (x + w), hh * (w - y), w};
    t.z[k] = v[2];
  }
  double Cx = 0.0, Cy = 0.0;
  for (int k = 0; k < 3; ++k) {
    t.c[k] = cross(V[(k + 1) % 3], V[(k + 2) % 3]);
    Cx = Cx + t.c[k].x;
    Cy = Cy + t.c[k].y;
  }
  t.Cx = Cx;
  t.Cy = Cy;
  t.D = dot(V[0], t.c[0]);
  return t;
}

// The terms of the last triangles seen, direct-mapped by id: a row crosses
// about a hundred triangles at 256 x 256 and the next rows cross most of them
// again. bench_iteration's sphere at 256 x 256 (callgrind): with 64 slots the
// terms were made at 83 % of the covered pixels, with 512 at 49 %, about once
// per visible triangle.
class ForwardCache {
 public:
  static constexpr std::size_t kSlots = 512;
  void clear() { tri_.fill(-1); }
  template <class T>
  const ForwardTerms& at(const BarycentricGBufferParams<T>& p, std::int64_t tri) {
    const std::size_t slot = static_cast<std::size_t>(tri) % kSlots;
    if (tri_[slot] != tri) terms_[slot] = forward_terms(p, tri), tri_[slot] = tri;
    return terms_[slot];
  }

 private:
  std::array<std::int64_t, kSlots> tri_;
  std::array<ForwardTerms, kSlots> terms_;
};

// The caches (60 KB each) are reused across calls, one per running chunk.
detail::ScratchPool<ForwardCache> g_forward_pool;

// One covered pixel's values at centre e = (ex, ey, 1) (formulas in
// barycentric_gbuffer.h; pixel_terms' and the clamps' arithmetic in the same
// order), all zero where S or D is zero or not finite. db only with kDerivatives.
struct PixelValues {
  double b0, b1, zw;
  double db[4];
};

template <bool kDerivatives>
[[gnu::always_inline]] inline void pixel_values(const ForwardTerms& t, double ex, double ey, PixelValues* v) {
  const HVec e{ex, ey, 1.0};
  double a[3], S = 0.0;
  for (int k = 0; k < 3; ++k) {
    a[k] = dot(e, t.c[k]);
    S += a[k];
  }
  if (!(S != 0.0 && t.D != 0.0 && std::isfinite(S) && std::isfinite(t.D))) {
    v->b0 = v->b1 = v->zw = 0.0;
    if (kDerivatives) v->db[0] = v->db[1] = v->db[2] = v->db[3] = 0.0;
    return;
  }
  double b0 = std::clamp(a[0] / S, 0.0, 1.0), b1 = std::clamp(a[1] / S, 0.0, 1.0);
  const double sum = b0 + b1;
  if (sum > 1.0) b0 /= sum, b1 /= sum;
  double zw = 0.0;
  for (int k = 0; k < 3; ++k) zw += a[k] * t.z[k];
  v->b0 = b0;
  v->b1 = b1;
  v->zw = std::clamp(zw / t.D, -1.0, 1.0);
  if (!kDerivatives) return;
  const double S2 = S * S;
  for (int k = 0; k < 2; ++k) {
    v->db[2 * k] = (t.c[k].x * S - a[k] * t.Cx) / S2;
    v->db[2 * k + 1] = (t.c[k].y * S - a[k] * t.Cy) / S2;
  }
}

// Where the forward writes: nvdiffrast's rast (H*W*4: b0, b1, z/w, id), or
// the C++ GBuffer's planes uv (H*W*2) and depth (H*W, background_depth on
// the background); db (H*W*4) or null either way.
template <class T>
struct ForwardOutputs {
  T* rast = nullptr;
  T* uv = nullptr;
  T* depth = nullptr;
  T background_depth = T(0);
  T* db = nullptr;
};

// The forward over whole rows, in parallel: each pixel's values from its
// triangle's terms (cached) and its centre (x + 0.5, y + 0.5), the doubles
// pixel_terms makes from the pixel index.
template <bool kPlanes, bool kDerivatives, class T>
void forward_rows(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, std::int64_t id_offset,
                  const ForwardOutputs<T>& o) {
  const int W = p.width;
  parallel_for(0, p.height, std::max(1, 4096 / W), [&](std::int64_t y0, std::int64_t y1) {
    auto lease = g_forward_pool.take();
    ForwardCache& cache = *lease;
    cache.clear();
    for (std::int64_t y = y0; y < y1; ++y) {
      const double ey = static_cast<double>(y) + 0.5;
      for (int x = 0; x < W; ++x) {
        const std::int64_t q = y * W + x;
        const std::int32_t id = tri_id[q];
        PixelValues v;
        std::int64_t tri = -1;
        if (id != 0) {
          tri = id_offset + id - 1;
          pixel_values<kDerivatives>(cache.at(p, tri), static_cast<double>(x) + 0.5, ey, &v);
        } else {
          v.b0 = v.b1 = v.zw = 0.0;
          if (kDerivatives) v.db[0] = v.db[1] = v.db[2] = v.db[3] = 0.0;
        }
        if constexpr (kPlanes) {
          o.uv[2 * q] = static_cast<T>(v.b0);
          o.uv[2 * q + 1] = static_cast<T>(v.b1);
          o.depth[q] = id != 0 ? static_cast<T>(v.zw) : o.background_depth;
        } else {
          T* r = o.rast + 4 * q;
          r[0] = static_cast<T>(v.b0);
          r[1] = static_cast<T>(v.b1);
          r[2] = static_cast<T>(v.zw);
          r[3] = static_cast<T>(tri + 1);
        }
        if constexpr (kDerivatives)
          for (int i = 0; i < 4; ++i) o.db[4 * q + i] = finite_cast<T>(v.db[i]);
      }
    }
  });
}

template <bool kPlanes, class T>
void forward_rows(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, std::int64_t id_offset,
                  const ForwardOutputs<T>& o) {
  if (o.db)
    forward_rows<kPlanes, true>(p, tri_id, id_offset, o);
  else
    forward_rows<kPlanes, false>(p, tri_id, id_offset, o);
}

}  // namespace

template <class T>
void barycentric_gbuffer_forward(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id,
                                 std::int64_t id_offset, T* rast, T* db) {
  ForwardOutputs<T> o;
  o.rast = rast;
  o.db = db;
  forward_rows<false>(p, tri_id, id_offset, o);
}

template <class T>
void barycentric_gbuffer_forward_planes(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, T* uv,
                                        T* depth, T background_depth, T* db) {
  ForwardOutputs<T> o;
  o.uv = uv;
  o.depth = depth;
  o.background_depth = background_depth;
  o.db = db;
  forward_rows<true>(p, tri_id, 0, o);
}

namespace {

// The adjoint's buffers, reused across calls (no page faults after the first).
detail::ScratchPool<detail::GatherScratch> g_backward_pool;

}  // namespace

template <class T>
void barycentric_gbuffer_backward(const BarycentricGBufferParams<T>& p, const T* rast, const T* grad_rast,
                                  const T* grad_db, T* grad_clip) {
  const std::int64_t pixels = static_cast<std::int64_t>(p.width) * p.height;
  // Scatter by gathering (docs/determinism.md): 1. covered pixels grouped by
  // triangle, in ascending pixel order; the used triangles numbered by first pixel.
  auto lease = g_backward_pool.take();
  detail::GatherScratch& sc = *lease;
  const detail::Buckets* shared = p.groups && p.tri_id ? p.groups->by_triangle(p.tri_id, pixels, p.num_tris) : nullptr;
  if (!shared)
    detail::bucket_items(pixels, p.num_tris, [&](std::int64_t q) { return pixel_id(p, rast, q) - 1; }, &sc.by_tri);
  const detail::Buckets& by_tri = shared ? *shared : sc.by_tri;
  const std::int64_t used = static_cast<std::int64_t>(by_tri.nonempty.size());
  // 2. Per used triangle s, in parallel: its pixels' dL/dclip of the three
  // vertices summed per corner in pixel order (corner k at partial[4 (3 s + k)]).
  sc.partial.resize(static_cast<std::size_t>(12 * used));
  sc.live.resize(static_cast<std::size_t>(used));
  double* const partial = sc.partial.data();
  parallel_for(0, used, 16, [&](std::int64_t s0, std::int64_t s1) {
    double contrib[12];
    for (std::int64_t s = s0; s < s1; ++s) {
      const std::int32_t tri = by_tri.nonempty[s];
      double* acc = partial + 12 * s;
      std::fill(acc, acc + 12, 0.0);
      std::uint8_t live = 0;
      std::optional<TriangleTerms> terms;  // computed at the first pixel with a gradient
      for (std::int64_t e = by_tri.start[tri]; e < by_tri.start[tri + 1]; ++e) {
        const std::int64_t q = by_tri.item[e];
        const T* g = grad_rast + 4 * q;
        const T* h = grad_db ? grad_db + 4 * q : nullptr;
        bool any = g[0] != T(0) || g[1] != T(0) || g[2] != T(0);
        if (h) any = any || h[0] != T(0) || h[1] != T(0) || h[2] != T(0) || h[3] != T(0);
        if (!any) continue;
        if (!terms) terms = triangle_terms(p, tri);
        pixel_adjoint(p, *terms, q, g, h, contrib);
        for (int i = 0; i < 12; ++i) acc[i] += contrib[i];
        live = 1;
      }
      sc.live[s] = live;
    }
  });
  // 3. Each vertex adds its corners' sums in corner order, once.
  detail::gather_corners(p.tris, by_tri.nonempty.data(), used, sc.live.data(), partial, 4, p.num_vertices,
                         &sc.by_vertex, [&](std::int64_t v, const double* total) {
                           for (int j = 0; j < 4; ++j) grad_clip[4 * v + j] += finite_cast<T>(total[j]);
                         });
}

#define GR_INSTANTIATE(T)                                                                                       \
  template void barycentric_gbuffer_forward<T>(const BarycentricGBufferParams<T>&, const std::int32_t*,         \
                                               std::int64_t, T*, T*);                                           \
  template void barycentric_gbuffer_forward_planes<T>(const BarycentricGBufferParams<T>&, const std::int32_t*,  \
                                                      T*, T*, T, T*);                                           \
  template void barycentric_gbuffer_backward<T>(const BarycentricGBufferParams<T>&, const T*, const T*, const T*, \
                                                T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
