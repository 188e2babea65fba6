// Rasterizer forward (tiled, watertight, deterministic depth test) and its
// adjoint (per-pixel contributions summed per triangle in pixel order, then
// gathered per vertex: docs/determinism.md, "Scatter by gathering").
//
// Forward: project vertices; classify triangles in parallel over fixed
// triangle chunks (frustum reject, area, culling, pixel bounding box) while
// counting each chunk's triangles per kTile x kTile screen tile (triangles
// with boxes of a few pixel centres are evaluated right there and binned as
// fragments, detail::classify_lanes); offsets chunk
// by chunk within each tile, then a fill per chunk, so every tile lists its triangles
// in ascending order for any thread count; then parallel_for over the
// non-empty tiles, each owning its pixels (empty tiles are never visited), so the
// (depth, id) test needs no atomics and is order independent. Buffers come
// from a scratch pool and are reused across calls.
#include "raster/rasterize.h"
#include "raster/detail/triangle_groups.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/detail/buckets.h"
#include "raster/detail/classify_lanes.h"
#include "raster/detail/corner_gather.h"
#include "raster/detail/guarded_math.h"
#include "raster/project.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/rasterize_scan.h"

namespace gr::raster {
namespace {

using detail::finite_cast;
using detail::safe_inv;

using detail::kTile;
using detail::kTilePixels;
using detail::scan_triangle;
using detail::TileBuffer;

// One triangle in one tile's list: its id and its pixel box clipped to the
// tile, in tile-local pixels, so the scan reads the box from the list (in
// sequence) instead of from the per-triangle array (a cache miss per entry).
struct BinEntry {
  std::int32_t id;
  std::uint8_t x0, y0, x1, y1;
};
static_assert(kTile <= 256, "tile-local box coordinates are 8-bit");

// Per-call buffers, reused across calls through a pool (allocated and
// page-faulted once; nothing is zero-filled serially).
struct ForwardScratch {
  detail::Vertices v;
  std::vector<detail::PixelBox> box;  // per triangle; x0 > x1 when not binned
  std::vector<double> zmin;           // per triangle, front_to_back only
  std::vector<std::int32_t> count;    // chunks x tiles: counts, then fill cursors
  std::vector<std::int64_t> offset;   // tiles + 1
  std::vector<BinEntry> bin;          // triangles, tile by tile
  std::vector<RasterStats> chunk_stats;
  // Fragments of small triangles (detail::lane_fragments), binned like the
  // triangles: per chunk in triangle order, then tile by tile.
  std::vector<std::vector<detail::Fragment>> chunk_frag;
  std::vector<std::int32_t> fcount;  // chunks x tiles: counts, then fill cursors
  std::vector<std::int64_t> foffset;  // tiles + 1
  std::vector<detail::Fragment> frag;
};
detail::ScratchPool<ForwardScratch> g_forward_pool;

// Triangles per binning chunk: a function of the triangle and tile counts only
// (never of the thread count): at least 4096, at most 64 chunks, and at most
// ~1M (chunk, tile) counters.
std::int64_t bin_chunk(std::int64_t num_tris, int tiles) {
  constexpr std::int64_t kMinChunk = 4096, kMaxChunks = 64, kMaxCounters = std::int64_t(1) << 20;
  const std::int64_t max_chunks = std::max<std::int64_t>(1, std::min(kMaxChunks, kMaxCounters / tiles));
  return std::max(kMinChunk, (num_tris + max_chunks - 1) / max_chunks);
}

// A value <= every depth the scan computes for triangle tri (screen form).
// Exactly, depth = sum lambda_k z_k >= min z_k; in floating point each edge
// value e_k has an absolute error below ~2^-50 (bw + 1)(bh + 1) (|px - ax| <= box
// width bw, |dy| <= box height bh, and so on), so sum lambda_k may fall short of
// 1 by 3 such errors / |2A|. The margin below covers that with room to spare.
double depth_lower_bound(const detail::Vertices& v, const std::int32_t* tri) {
  const double* p[3] = {&v.screen[3 * static_cast<std::size_t>(tri[0])],
                        &v.screen[3 * static_cast<std::size_t>(tri[1])],
                        &v.screen[3 * static_cast<std::size_t>(tri[2])]};
  const double bw = std::max({p[0][0], p[1][0], p[2][0]}) - std::min({p[0][0], p[1][0], p[2][0]});
  const double bh = std::max({p[0][1], p[1][1], p[2][1]}) - std::min({p[0][1], p[1][1], p[2][1]});
  const double a2 = std::abs((p[0][0] - p[1][0]) * (p[2][1] - p[1][1]) -
                             (p[0][1] - p[1][1]) * (p[2][0] - p[1][0]));
  const double zmin = std::min({p[0][2], p[1][2], p[2][2]});
  const double zabs = std::max({std::abs(p[0][2]), std::abs(p[1][2]), std::abs(p[2][2])});
  const double rel = std::ldexp(1.0, -40) * ((bw + 2.0) * (bh + 2.0) / a2 + 1.0);
  return zmin - zabs * rel;
}

// Scans the tile's triangles into tb. With front_to_back, the list is visited
// by ascending (zmin, id) and a triangle whose smallest vertex depth is beyond
// the tile's largest stored depth (all pixels covered) is skipped: each of its
// pixels would fail z < zbuf, so the result is the same.
// x rounded to T, saturated at T's largest finite value: a G-buffer is
// finite for any accepted input, also where float32 clip values near FLT_MAX
// give weights beyond float32's range (found by the fuzz_raster smoke).
template <class T>
T saturate(double x) {
  constexpr double kMax = static_cast<double>(std::numeric_limits<T>::max());
  return static_cast<T>(x > kMax ? kMax : x < -kMax ? -kMax : x);
}

// The vertices of a mesh's triangles are scattered over arrays larger than
// the cache: the loops over triangles ask for them this many triangles ahead.
constexpr int kPrefetchAhead = 8;
inline void prefetch_vertices(const detail::Vertices& v, const std::int32_t* tri) {
  for (int k = 0; k < 3; ++k) {
    __builtin_prefetch(&v.screen[3 * static_cast<std::size_t>(tri[k])]);
    __builtin_prefetch(&v.outcode[tri[k]]);
    __builtin_prefetch(&v.front[tri[k]]);
  }
}

template <class T>
void scan_tile(const detail::Vertices& v, const RasterParams<T>& p, const ForwardScratch& sc,
               int tiles_x, int tile, int width, int height, bool front_to_back,
               std::vector<BinEntry>& order, TileBuffer& tb) {
  const std::int32_t* tris = p.tris;
  const int tx0 = (tile % tiles_x) * kTile, ty0 = (tile / tiles_x) * kTile;
  const int tx1 = std::min(tx0 + kTile, width) - 1, ty1 = std::min(ty0 + kTile, height) - 1;
  const int area = (tx1 - tx0 + 1) * (ty1 - ty0 + 1);
  std::fill(tb.z, tb.z + kTilePixels, std::numeric_limits<double>::infinity());
  std::fill(tb.id, tb.id + kTilePixels, -1);
  tb.covered = 0;
  tb.zmax = std::numeric_limits<double>::infinity();
  tb.floor = p.floor_id != nullptr;
  if (tb.floor) {
    // The previous layer's key per pixel; behind its background nothing remains.
    for (int y = 0; y <= ty1 - ty0; ++y)
      for (int x = 0; x <= tx1 - tx0; ++x) {
        const std::int64_t px = static_cast<std::int64_t>(ty0 + y) * width + tx0 + x;
        const bool empty = p.floor_id[px] == 0;
        tb.fz[y * kTile + x] = empty ? std::numeric_limits<double>::infinity() : p.floor_z[px];
        tb.fid[y * kTile + x] = empty ? std::numeric_limits<std::int32_t>::max() : p.floor_id[px] - 1;
      }
  }
  detail::resolve_fragments(sc.frag.data() + sc.foffset[tile], sc.foffset[tile + 1] - sc.foffset[tile], tb);
  const BinEntry* list = sc.bin.data() + sc.offset[tile];
  const std::int64_t n = sc.offset[tile + 1] - sc.offset[tile];
  auto scan = [&](const BinEntry& b) {
    const detail::PixelBox box{tx0 + b.x0, ty0 + b.y0, tx0 + b.x1, ty0 + b.y1};
    scan_triangle(v, tris, b.id, box, tx0, ty0, tx1, ty1, width, height, tb);
  };
  if (!front_to_back) {
    // A tile's triangles are sparse in the triangle array: their indices are
    // fetched two look-aheads early, their vertices one.
    for (std::int64_t i = 0; i < n; ++i) {
      if (i + 2 * kPrefetchAhead < n) __builtin_prefetch(tris + 3 * static_cast<std::int64_t>(list[i + 2 * kPrefetchAhead].id));
      if (i + kPrefetchAhead < n) prefetch_vertices(v, tris + 3 * static_cast<std::int64_t>(list[i + kPrefetchAhead].id));
      scan(list[i]);
    }
    return;
  }
  order.assign(list, list + n);
  const double* zmin = sc.zmin.data();
  std::sort(order.begin(), order.end(), [zmin](const BinEntry& a, const BinEntry& b) {
    return zmin[a.id] < zmin[b.id] || (zmin[a.id] == zmin[b.id] && a.id < b.id);
  });
  int since = 0;  // triangles scanned since zmax was last refreshed
  for (const BinEntry& e : order) {
    const std::int32_t t = e.id;
    if (tb.covered == area && (since >= 8 || tb.zmax == std::numeric_limits<double>::infinity())) {
      // Refresh the tile's farthest stored depth (unused slots hold +inf).
      double m = -std::numeric_limits<double>::infinity();
      for (int y = 0; y <= ty1 - ty0; ++y)
        for (int x = 0; x <= tx1 - tx0; ++x) m = std::max(m, tb.z[y * kTile + x]);
      tb.zmax = m;
      since = 0;
    }
    if (zmin[t] > tb.zmax) continue;
    scan(e);
    ++since;
  }
}

// The tile grid and triangle chunks of one forward call. Chunks depend on the
// triangle and tile counts only, never on the thread count.
struct Grid {
  int width, height, tiles_x, tiles;
  std::int64_t chunk, chunks;
};

Grid make_grid(std::int64_t num_tris, int width, int height) {
  Grid g;
  g.width = width;
  g.height = height;
  g.tiles_x = (width + kTile - 1) / kTile;
  g.tiles = g.tiles_x * ((height + kTile - 1) / kTile);
  g.chunk = bin_chunk(num_tris, g.tiles);
  g.chunks = (num_tris + g.chunk - 1) / g.chunk;
  return g;
}

// Phase 2 (parallel over the triangle chunks): classify every triangle,
// keep its pixel box (and, front to back, its depth lower bound), and count
// each chunk's triangles per tile. Returns the summed triangle counts.
template <class T>
RasterStats classify_and_count(const RasterParams<T>& p, const Grid& g, ForwardScratch& sc) {
  const detail::Vertices& v = sc.v;
  const Cull cull_mode = p.settings.cull;
  const int cull = cull_mode == Cull::Back ? 1 : cull_mode == Cull::Front ? -1 : 0;
  const bool f2b = p.settings.front_to_back;
  sc.box.resize(static_cast<std::size_t>(p.num_tris));
  if (f2b) sc.zmin.resize(static_cast<std::size_t>(p.num_tris));
  sc.count.resize(static_cast<std::size_t>(g.chunks) * g.tiles);
  sc.chunk_stats.assign(static_cast<std::size_t>(g.chunks), RasterStats{});
  sc.fcount.resize(static_cast<std::size_t>(g.chunks) * g.tiles);
  if (sc.chunk_frag.size() < static_cast<std::size_t>(g.chunks)) sc.chunk_frag.resize(static_cast<std::size_t>(g.chunks));
  parallel_for(0, g.chunks, 1, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      std::int32_t* cnt = &sc.count[static_cast<std::size_t>(c) * g.tiles];
      std::fill(cnt, cnt + g.tiles, 0);
      std::int32_t* fcnt = &sc.fcount[static_cast<std::size_t>(c) * g.tiles];
      std::fill(fcnt, fcnt + g.tiles, 0);
      std::vector<detail::Fragment>& frag = sc.chunk_frag[c];
      frag.clear();
      RasterStats& st = sc.chunk_stats[c];
      const std::int64_t t0 = c * g.chunk, t1 = std::min(p.num_tris, (c + 1) * g.chunk);
      detail::TriClass lane_class[detail::kClassifyLanes];
      detail::LaneCoverage lane_cover;
      for (std::int64_t t = t0; t < t1; ++t) {
        const std::int32_t* tri = p.tris + 3 * t;
        // The next batch's vertices, asked for while this one is finished.
        if (t + detail::kClassifyLanes < t1) prefetch_vertices(v, tri + 3 * detail::kClassifyLanes);
        const int lane = static_cast<int>((t - t0) % detail::kClassifyLanes);
        if (lane == 0)
          detail::classify_lanes(v, p.tris, t, static_cast<int>(std::min<std::int64_t>(detail::kClassifyLanes, t1 - t)),
                                 g.width, g.height, cull, lane_class, &sc.box[t], &lane_cover);
        detail::PixelBox& b = sc.box[t];
        detail::TriClass k = lane_class[lane];
        if (k == detail::TriClass::Clipped) k = detail::classify_triangle(v, tri, g.width, g.height, cull, &b);
        // Triangles of a finely tessellated mesh mostly have boxes of a few
        // pixel centres: the lanes evaluated those (and rejected the ones
        // covering no centre); their fragments are binned instead of the
        // triangle, which would be set up again per tile.
        bool small = false;
        if (k == detail::TriClass::Raster &&
            (b.x1 - b.x0 + 1) * (b.y1 - b.y0 + 1) <= detail::kMaxFragmentBox) {
          detail::Fragment f[detail::kMaxFragmentBox];
          const int emitted =
              detail::lane_fragments(v, p.tris, static_cast<std::int32_t>(t), b, lane_cover, lane, g.tiles_x, f);
          for (int i = 0; i < emitted; ++i) {
            ++fcnt[f[i].where / kTilePixels];
            frag.push_back(f[i]);
          }
          small = true;
        }
        switch (k) {
          case detail::TriClass::Outside: ++st.culled_outside; break;
          case detail::TriClass::ZeroArea: ++st.culled_zero_area; break;
          case detail::TriClass::Face: ++st.culled_face; break;
          case detail::TriClass::NoPixel: ++st.culled_no_pixel; break;
          case detail::TriClass::Clipped: ++st.clipped_near; break;
          case detail::TriClass::Raster: ++st.rasterized; break;
        }
        if ((k != detail::TriClass::Raster && k != detail::TriClass::Clipped) || small) {
          b = {1, 1, 0, 0};  // not binned
          continue;
        }
        if (f2b)
          sc.zmin[t] = k == detail::TriClass::Clipped ? -std::numeric_limits<double>::infinity()
                                                      : depth_lower_bound(v, tri);
        for (int ty = b.y0 / kTile; ty <= b.y1 / kTile; ++ty)
          for (int tx = b.x0 / kTile; tx <= b.x1 / kTile; ++tx) ++cnt[ty * g.tiles_x + tx];
      }
    }
  });
  RasterStats st;
  st.triangles_in = p.num_tris;
  for (const RasterStats& c : sc.chunk_stats) {
    st.culled_outside += c.culled_outside;
    st.culled_zero_area += c.culled_zero_area;
    st.culled_face += c.culled_face;
    st.culled_no_pixel += c.culled_no_pixel;
    st.clipped_near += c.clipped_near;
    st.rasterized += c.rasterized;
  }
  return st;
}

// Phase 3: offsets tile by tile, chunks in order within a tile, so each
// tile's list is in ascending triangle order. Counts become each (chunk,
// tile) cursor; the bin array is sized.
void bin_offsets(const Grid& g, ForwardScratch& sc) {
  sc.offset.resize(static_cast<std::size_t>(g.tiles) + 1);
  std::int64_t run = 0;
  for (int i = 0; i < g.tiles; ++i) {
    sc.offset[i] = run;
    for (std::int64_t c = 0; c < g.chunks; ++c) {
      std::int32_t& a = sc.count[static_cast<std::size_t>(c) * g.tiles + i];
      const std::int64_t n = a;
      a = static_cast<std::int32_t>(run - sc.offset[i]);  // cursor relative to the tile start
      run += n;
    }
  }
  sc.offset[g.tiles] = run;
  sc.bin.resize(static_cast<std::size_t>(run));
  sc.foffset.resize(static_cast<std::size_t>(g.tiles) + 1);
  run = 0;
  for (int i = 0; i < g.tiles; ++i) {
    sc.foffset[i] = run;
    for (std::int64_t c = 0; c < g.chunks; ++c) {
      std::int32_t& a = sc.fcount[static_cast<std::size_t>(c) * g.tiles + i];
      const std::int64_t n = a;
      a = static_cast<std::int32_t>(run - sc.foffset[i]);
      run += n;
    }
  }
  sc.foffset[g.tiles] = run;
  sc.frag.resize(static_cast<std::size_t>(run));
}

// Phase 4 (parallel over the same chunks): each chunk writes its triangle ids
// into its own slots of the tiles it touches.
void fill_bins(std::int64_t num_tris, const Grid& g, ForwardScratch& sc) {
  parallel_for(0, g.chunks, 1, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      std::int32_t* fill = &sc.count[static_cast<std::size_t>(c) * g.tiles];
      std::int32_t* ffill = &sc.fcount[static_cast<std::size_t>(c) * g.tiles];
      for (const detail::Fragment& f : sc.chunk_frag[c]) {
        const int i = f.where / kTilePixels;
        sc.frag[sc.foffset[i] + ffill[i]++] = f;
      }
      const std::int64_t t1 = std::min(num_tris, (c + 1) * g.chunk);
      for (std::int64_t t = c * g.chunk; t < t1; ++t) {
        const detail::PixelBox& b = sc.box[t];
        if (b.x0 > b.x1) continue;
        for (int ty = b.y0 / kTile; ty <= b.y1 / kTile; ++ty) {
          const int y0 = std::max(b.y0 - ty * kTile, 0), y1 = std::min(b.y1 - ty * kTile, kTile - 1);
          for (int tx = b.x0 / kTile; tx <= b.x1 / kTile; ++tx) {
            const int x0 = std::max(b.x0 - tx * kTile, 0), x1 = std::min(b.x1 - tx * kTile, kTile - 1);
            const int i = ty * g.tiles_x + tx;
            sc.bin[sc.offset[i] + fill[i]++] = {static_cast<std::int32_t>(t), static_cast<std::uint8_t>(x0),
                                                static_cast<std::uint8_t>(y0), static_cast<std::uint8_t>(x1),
                                                static_cast<std::uint8_t>(y1)};
          }
        }
      }
    }
  });
}

// Phase 5: background everywhere (one parallel pass).
template <class T>
void clear_background(std::int64_t pixels, std::int32_t* tri_id, T* uv, T* depth) {
  parallel_for(0, pixels, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    std::fill(tri_id + lo, tri_id + hi, 0);
    std::fill(uv + 2 * lo, uv + 2 * hi, T(0));
    std::fill(depth + lo, depth + hi, T(kBackgroundDepth));
  });
}

// Phase 6 (parallel over the non-empty tiles): scan each tile's triangles
// and write its covered pixels; each tile writes only its own pixels.
template <class T>
void scan_tiles(const RasterParams<T>& p, const Grid& g, const ForwardScratch& sc, std::int32_t* tri_id, T* uv,
                T* depth, double* key_depth) {
  std::vector<int> busy;
  for (int i = 0; i < g.tiles; ++i)
    if (sc.offset[i + 1] > sc.offset[i] || sc.foffset[i + 1] > sc.foffset[i]) busy.push_back(i);
  const int W = g.width, H = g.height;
  parallel_for(0, static_cast<std::int64_t>(busy.size()), 1, [&](std::int64_t lo, std::int64_t hi) {
    std::unique_ptr<TileBuffer> tb(new TileBuffer);
    std::vector<BinEntry> order;
    for (std::int64_t n = lo; n < hi; ++n) {
      const int tile = busy[n];
      scan_tile(sc.v, p, sc, g.tiles_x, tile, W, H, p.settings.front_to_back, order, *tb);
      const int tx0 = (tile % g.tiles_x) * kTile, ty0 = (tile / g.tiles_x) * kTile;
      const int tw = std::min(kTile, W - tx0), th = std::min(kTile, H - ty0);
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) {
          const int q = y * kTile + x;
          if (tb->id[q] < 0) continue;
          const std::int64_t px = static_cast<std::int64_t>(ty0 + y) * W + tx0 + x;
          tri_id[px] = tb->id[q] + 1;
          uv[2 * px] = saturate<T>(tb->u[q]);
          uv[2 * px + 1] = saturate<T>(tb->v[q]);
          depth[px] = saturate<T>(tb->z[q]);
          if (key_depth) key_depth[px] = tb->z[q];
        }
    }
  });
}

}  // namespace

template <class T>
void rasterize_forward(const RasterParams<T>& p, std::int32_t* tri_id, T* uv, T* depth, RasterStats* stats,
                       double* key_depth) {
  const int W = p.settings.width, H = p.settings.height;
  assert(W >= 1 && H >= 1 && p.num_vertices >= 0 && p.num_tris >= 0);
  auto lease = g_forward_pool.take();
  ForwardScratch& sc = *lease;
  // Phase 1: per-vertex projection.
  detail::project_vertices_into(p.clip, p.num_vertices, W, H, &sc.v, p.settings.y_up);
  const Grid g = make_grid(p.num_tris, W, H);
  const RasterStats st = classify_and_count(p, g, sc);
  if (stats) *stats = st;
  bin_offsets(g, sc);
  fill_bins(p.num_tris, g, sc);
  clear_background(static_cast<std::int64_t>(W) * H, tri_id, uv, depth);
  if (key_depth) std::fill(key_depth, key_depth + static_cast<std::int64_t>(W) * H, std::numeric_limits<double>::infinity());
  scan_tiles(p, g, sc, tri_id, uv, depth, key_depth);
}

namespace {

// A triangle's screen positions (x_k, y_k, z_ndc) and 1 / 2A, 2A = E(p0; p1, p2):
// the part of pixel_grads_screen that does not depend on the pixel, computed
// once per triangle.
struct ScreenTriangle {
  const double *p0, *p1, *p2;
  double inv;
};

inline double edge_function(double qx, double qy, const double* a, const double* b) {
  return (qx - a[0]) * (b[1] - a[1]) - (qy - a[1]) * (b[0] - a[0]);
}

ScreenTriangle screen_triangle(const detail::Vertices& v, const std::int32_t* tri) {
  ScreenTriangle st{&v.screen[3 * static_cast<std::size_t>(tri[0])], &v.screen[3 * static_cast<std::size_t>(tri[1])],
                    &v.screen[3 * static_cast<std::size_t>(tri[2])], 0.0};
  st.inv = safe_inv(edge_function(st.p0[0], st.p0[1], st.p1, st.p2));
  return st;
}

// Pixels the adjoint's walk over a triangle in front of the near plane takes at
// once (lanes of its vector arithmetic; 16 for the reason given in
// interpolate.cpp).
constexpr int kLanes = 16;

// Gradient of the screen-space triangle functions at kLanes pixels: the adjoint of
//   u = E_20/2A, v = E_01/2A, depth = (1-u-v) z0 + u z1 + v z2
// w.r.t. the screen positions (x_k, y_k) and z_k = z_ndc; grad[3k + d][lane].
// The partials of E(q; a, b) = (qx-ax)(by-ay) - (qy-ay)(bx-ax) are
// dE/da = (qy-by, bx-qx), dE/db = (ay-qy, qx-ax), dE/dq = (by-ay, ax-bx).
inline void pixel_grads_screen(const ScreenTriangle& st, const double* px, const double* py, const double* gu,
                               const double* gv, const double* gd, double (*grad)[kLanes]) {
  const double x0 = st.p0[0], y0 = st.p0[1], z0 = st.p0[2];
  const double x1 = st.p1[0], y1 = st.p1[1], z1 = st.p1[2];
  const double x2 = st.p2[0], y2 = st.p2[1], z2 = st.p2[2];
  const double inv = st.inv;
  for (int i = 0; i < kLanes; ++i) {
    const double qx = px[i], qy = py[i];
    const double u = ((qx - x2) * (y0 - y2) - (qy - y2) * (x0 - x2)) * inv;
    const double v = ((qx - x0) * (y1 - y0) - (qy - y0) * (x1 - x0)) * inv;
    // Depth reaches u and v too; then the quotient rule on u = E_20/2A, v = E_01/2A.
    const double gu2 = gu[i] + gd[i] * (z1 - z0), gv2 = gv[i] + gd[i] * (z2 - z0);
    const double g20 = gu2 * inv, g01 = gv2 * inv, ga2 = -(gu2 * u + gv2 * v) * inv;
    // E_20 = E(q; p2, p0).
    double g2x = 0.0 + g20 * (qy - y0), g2y = 0.0 + g20 * (x0 - qx);
    double g0x = 0.0 + g20 * (y2 - qy), g0y = 0.0 + g20 * (qx - x2);
    // E_01 = E(q; p0, p1).
    g0x += g01 * (qy - y1);
    g0y += g01 * (x1 - qx);
    double g1x = 0.0 + g01 * (y0 - qy), g1y = 0.0 + g01 * (qx - x0);
    // 2A = E(p0; p1, p2), p0 also as the query point.
    g1x += ga2 * (y0 - y2);
    g1y += ga2 * (x2 - x0);
    g2x += ga2 * (y1 - y0);
    g2y += ga2 * (x0 - x1);
    g0x += ga2 * (y2 - y1);
    g0y += ga2 * (x1 - x2);
    // Depth w.r.t. z_ndc: the barycentric weights.
    grad[0][i] = g0x;
    grad[1][i] = g0y;
    grad[2][i] = 0.0 + gd[i] * (1.0 - u - v);
    grad[3][i] = g1x;
    grad[4][i] = g1y;
    grad[5][i] = 0.0 + gd[i] * u;
    grad[6][i] = g2x;
    grad[7][i] = g2y;
    grad[8][i] = 0.0 + gd[i] * v;
  }
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

// The adjoint's walk over one triangle in front of the near plane, vectorized
// across pixels: each batch of the triangle's pixels (ascending) is gathered
// into per-lane arrays, pixel_grads_screen computes their terms, and they
// are added to the corner sums in pixel order, skipping pixels with a zero
// incoming gradient: the same arithmetic in the same order as pixel by pixel.
// Writes corner k's screen sums to acc[k S, k S + 3); returns whether any
// pixel had a gradient.
template <class T>
bool sum_screen_pixels(const ScreenTriangle& st, const std::int32_t* pixel, std::int64_t count, int width,
                       const T* grad_uv, const T* grad_depth, std::int64_t S, double* acc) {
  double sums[9] = {};
  bool live = false;
  for (std::int64_t e0 = 0; e0 < count; e0 += kLanes) {
    const int n = static_cast<int>(std::min<std::int64_t>(kLanes, count - e0));
    // Gather (lanes past n are zeros, computed and never used); fetch the
    // next batch's gradients early, as the walk jumps between pixel rows.
    double px[kLanes], py[kLanes], gu[kLanes], gv[kLanes], gd[kLanes];
    for (int i = 0; i < kLanes; ++i) {
      if (e0 + kLanes + i < count) __builtin_prefetch(grad_uv + 2 * static_cast<std::int64_t>(pixel[e0 + kLanes + i]));
      const std::int64_t q = i < n ? pixel[e0 + i] : 0;
      px[i] = static_cast<double>(q % width) + 0.5;
      py[i] = static_cast<double>(q / width) + 0.5;
      gu[i] = i < n ? static_cast<double>(grad_uv[2 * q]) : 0.0;
      gv[i] = i < n ? static_cast<double>(grad_uv[2 * q + 1]) : 0.0;
      gd[i] = i < n && grad_depth ? static_cast<double>(grad_depth[q]) : 0.0;
    }
    double grad[9][kLanes];
    pixel_grads_screen(st, px, py, gu, gv, gd, grad);
    for (int i = 0; i < n; ++i) {
      if (gu[i] == 0.0 && gv[i] == 0.0 && gd[i] == 0.0) continue;
      live = true;
      for (int j = 0; j < 9; ++j) sums[j] += grad[j][i];
    }
  }
  for (int k = 0; k < 3; ++k)
    for (int d = 0; d < 3; ++d) acc[k * S + d] = sums[3 * k + d];
  return live;
}

// Per-call buffers of rasterize_backward, reused through a pool.
struct BackwardScratch {
  detail::Vertices v;
  detail::Buckets by_tri, by_vertex;
  std::vector<double> acc_screen, acc_clip, partial;
  std::vector<std::uint8_t> kind;
};
detail::ScratchPool<BackwardScratch> g_backward_pool;

// data[0, n) = 0, in parallel.
void parallel_fill(double* data, std::int64_t n) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    std::fill(data + lo, data + hi, 0.0);
  });
}

}  // namespace

template <class T>
void rasterize_backward(const RasterParams<T>& p, const std::int32_t* tri_id, const T* grad_uv, const T* grad_depth,
                        T* grad_clip, TriangleGroups* groups) {
  const T* clip = p.clip;
  const std::int64_t num_vertices = p.num_vertices;
  const std::int32_t* tris = p.tris;
  const int W = p.settings.width, H = p.settings.height;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;
  auto lease = g_backward_pool.take();
  BackwardScratch& sc = *lease;
  const bool y_up = p.settings.y_up;
  detail::project_vertices_into(clip, num_vertices, W, H, &sc.v, y_up);
  const detail::Vertices& v = sc.v;

  // Scatter by gathering (docs/determinism.md): 1. covered pixels grouped by
  // triangle, in pixel order; used triangles numbered by first pixel.
  const detail::Buckets* shared = groups ? groups->by_triangle(tri_id, P, p.num_tris) : nullptr;
  if (!shared)
    detail::bucket_items(P, p.num_tris, [&](std::int64_t q) -> std::int64_t { return tri_id[q] - 1; }, &sc.by_tri);
  const detail::Buckets& by_tri = shared ? *shared : sc.by_tri;
  const std::int64_t used = static_cast<std::int64_t>(by_tri.nonempty.size());

  // 2. Per triangle, in parallel: each pixel's contribution, summed per corner
  // in pixel order. Corner k of used triangle s: 7 doubles at (3 s + k) 7,
  // screen (x, y, z_ndc) then clip (x, y, z, w); kind[s]: 0 no gradient,
  // 1 screen (all vertices in front), 2 clip (homogeneous form).
  constexpr std::int64_t S = 7;
  std::vector<double>& partial = sc.partial;
  std::vector<std::uint8_t>& kind = sc.kind;
  partial.resize(static_cast<std::size_t>(3 * S * used));
  kind.resize(static_cast<std::size_t>(used));
  parallel_for(0, used, 16, [&](std::int64_t s0, std::int64_t s1) {
    double out[12];
    for (std::int64_t s = s0; s < s1; ++s) {
      double* acc = &partial[static_cast<std::size_t>(3 * S * s)];
      std::fill(acc, acc + 3 * S, 0.0);
      const std::int64_t t = by_tri.nonempty[s];
      const std::int32_t* tri = tris + 3 * t;
      const std::int64_t e0 = by_tri.start[t], e1 = by_tri.start[t + 1];
      if (!detail::needs_clipping(v, tri)) {
        const bool live = sum_screen_pixels(screen_triangle(v, tri), by_tri.item.data() + e0, e1 - e0, W, grad_uv,
                                            grad_depth, S, acc);
        kind[s] = live ? 1 : 0;
        continue;
      }
      // Clipped: the homogeneous form, pixel by pixel.
      std::uint8_t k = 0;
      for (std::int64_t e = e0; e < e1; ++e) {
        const std::int64_t q = by_tri.item[e];
        // The walk jumps between pixel rows: fetch a later pixel's gradient early.
        if (e + 4 < e1) __builtin_prefetch(grad_uv + 2 * static_cast<std::int64_t>(by_tri.item[e + 4]));
        const double gu = grad_uv[2 * q], gv = grad_uv[2 * q + 1];
        const double gd = grad_depth ? static_cast<double>(grad_depth[q]) : 0.0;
        // Zero incoming gradient: skip.
        if (gu == 0.0 && gv == 0.0 && gd == 0.0) continue;
        const double px = static_cast<double>(q % W) + 0.5, py = static_cast<double>(q / W) + 0.5;
        std::fill(out, out + 12, 0.0);
        pixel_grad_homogeneous(v, tri, W, H, px, py, gu, gv, gd, out);
        for (int j = 0; j < 3; ++j)
          for (int d = 0; d < 4; ++d) acc[j * S + 3 + d] += out[4 * j + d];
        k = 2;
      }
      kind[s] = k;
    }
  });
  bool any_screen = false, any_clip = false;
  for (std::uint8_t k : kind) {
    any_screen |= k == 1;
    any_clip |= k == 2;
  }

  // 3. Per-vertex accumulators, screen (x, y, z_ndc) and clip (x, y, z, w):
  // zeroed in parallel, then each vertex adds its corners in corner order.
  std::vector<double>& acc_screen = sc.acc_screen;
  std::vector<double>& acc_clip = sc.acc_clip;
  acc_screen.resize(3 * static_cast<std::size_t>(num_vertices));
  parallel_fill(acc_screen.data(), 3 * num_vertices);
  if (any_clip) {
    acc_clip.resize(4 * static_cast<std::size_t>(num_vertices));
    parallel_fill(acc_clip.data(), 4 * num_vertices);
  }
  detail::gather_corners(tris, by_tri.nonempty.data(), used, kind.data(), partial.data(), S, num_vertices,
                         &sc.by_vertex, [&](std::int64_t i, const double* total) {
                           for (int d = 0; d < 3; ++d) acc_screen[3 * i + d] = total[d];
                           if (any_clip) {
                             for (int d = 0; d < 4; ++d) acc_clip[4 * i + d] = total[3 + d];
                             // The homogeneous form's y is the negated one (y_up).
                             acc_clip[4 * i + 1] = detail::seen_y(acc_clip[4 * i + 1], y_up);
                           }
                         });

  // Screen -> NDC -> clip per vertex with the projection adjoints.
  if (any_screen) screen_to_clip_backward(clip, num_vertices, W, H, acc_screen.data(), 3, grad_clip, y_up);
  if (any_clip)
    parallel_for(0, 4 * num_vertices, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t i = lo; i < hi; ++i) grad_clip[i] += finite_cast<T>(acc_clip[i]);
    });
}

#define GR_INSTANTIATE(T)                                                                                \
  template void rasterize_forward<T>(const RasterParams<T>&, std::int32_t*, T*, T*, RasterStats*, double*); \
  template void rasterize_backward<T>(const RasterParams<T>&, const std::int32_t*, const T*, const T*, T*, \
                                      TriangleGroups*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
