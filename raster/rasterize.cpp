// Rasterizer forward (tiled, watertight, deterministic depth test): project
// vertices; classify triangles in parallel over fixed triangle chunks (frustum reject, area, culling, pixel bounding box) while
// counting each chunk's triangles per kTile x kTile screen tile (triangles
// with boxes of a few pixel centres are evaluated right there and binned as
// fragments, detail::classify_lanes); offsets chunk
// by chunk within each tile, then a fill per chunk, so every tile lists its triangles
// in ascending order for any thread count; then parallel_for over the
// non-empty tiles, each owning its pixels (empty tiles are never visited), so the
// (depth, id) test needs no atomics and is order independent. Buffers come
// from a scratch pool and are reused across calls.
#include "raster/rasterize.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/detail/classify_lanes.h"
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
  detail::Vertices own;          // the projection, unless the caller keeps it
  const detail::Vertices* v = nullptr;  // the call's projection: &own or the caller's
  std::vector<detail::PixelBox> box;  // per triangle; x0 > x1 when not binned
  std::vector<double> zmin;           // per triangle, front_to_back only
  std::vector<std::int32_t> count;    // chunks x tiles: counts, then fill cursors
  std::vector<std::int64_t> offset;   // tiles + 1
  std::vector<BinEntry> bin;          // triangles, tile by tile
  std::vector<RasterStats> chunk_stats;
  // Fragments of small triangles (detail::lane_fragments), binned like the
  // triangles: per chunk in triangle order, then tile by tile.
  std::vector<std::vector<detail::Fragment>> chunk_frag;
  // The binned triangles per chunk, ascending: the fill visits only those
  // (issue 31: below a few pixels a triangle is a fragment or culled, and
  // walking all triangles again was a fixed cost per view).
  std::vector<std::vector<std::int32_t>> chunk_binned;
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
// Below this many vertices, what those loops read of them (26 bytes a vertex)
// stays in the L2 cache: asking ahead would cost ~20 instructions a triangle
// for nothing (issue 31: a small mesh's fixed cost per view).
constexpr std::int64_t kPrefetchVertices = 8192;
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
  if (!front_to_back && p.num_vertices < kPrefetchVertices) {
    for (std::int64_t i = 0; i < n; ++i) scan(list[i]);
    return;
  }
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
  const detail::Vertices& v = *sc.v;
  const Cull cull_mode = p.settings.cull;
  const int cull = cull_mode == Cull::Back ? 1 : cull_mode == Cull::Front ? -1 : 0;
  const bool f2b = p.settings.front_to_back;
  const bool prefetch = p.num_vertices >= kPrefetchVertices;
  sc.box.resize(static_cast<std::size_t>(p.num_tris));
  if (f2b) sc.zmin.resize(static_cast<std::size_t>(p.num_tris));
  sc.count.resize(static_cast<std::size_t>(g.chunks) * g.tiles);
  sc.chunk_stats.assign(static_cast<std::size_t>(g.chunks), RasterStats{});
  sc.fcount.resize(static_cast<std::size_t>(g.chunks) * g.tiles);
  if (sc.chunk_frag.size() < static_cast<std::size_t>(g.chunks)) sc.chunk_frag.resize(static_cast<std::size_t>(g.chunks));
  if (sc.chunk_binned.size() < static_cast<std::size_t>(g.chunks))
    sc.chunk_binned.resize(static_cast<std::size_t>(g.chunks));
  parallel_for(0, g.chunks, 1, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      std::int32_t* cnt = &sc.count[static_cast<std::size_t>(c) * g.tiles];
      std::fill(cnt, cnt + g.tiles, 0);
      std::int32_t* fcnt = &sc.fcount[static_cast<std::size_t>(c) * g.tiles];
      std::fill(fcnt, fcnt + g.tiles, 0);
      std::vector<detail::Fragment>& frag = sc.chunk_frag[c];
      frag.clear();
      std::vector<std::int32_t>& binned = sc.chunk_binned[c];
      binned.clear();
      RasterStats& st = sc.chunk_stats[c];
      const std::int64_t t0 = c * g.chunk, t1 = std::min(p.num_tris, (c + 1) * g.chunk);
      detail::TriClass lane_class[detail::kClassifyLanes];
      detail::LaneCoverage lane_cover;
      std::int64_t tally[6] = {};  // triangles per TriClass (0..5)
      for (std::int64_t t = t0, batch = t0, batch_end = t0; t < t1; ++t) {
        const std::int32_t* tri = p.tris + 3 * t;
        // The next batch's vertices, asked for while this one is finished.
        if (prefetch && t + detail::kClassifyLanes < t1) prefetch_vertices(v, tri + 3 * detail::kClassifyLanes);
        if (t == batch_end) {
          batch = t;
          batch_end = std::min(t1, t + detail::kClassifyLanes);
          detail::classify_lanes(v, p.tris, t, static_cast<int>(batch_end - t), g.width, g.height, cull, lane_class,
                                 &sc.box[t], &lane_cover);
        }
        const int lane = static_cast<int>(t - batch);
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
        ++tally[static_cast<int>(k)];
        if ((k != detail::TriClass::Raster && k != detail::TriClass::Clipped) || small) {
          b = {1, 1, 0, 0};  // not binned
          continue;
        }
        if (f2b)
          sc.zmin[t] = k == detail::TriClass::Clipped ? -std::numeric_limits<double>::infinity()
                                                      : depth_lower_bound(v, tri);
        binned.push_back(static_cast<std::int32_t>(t));
        for (int ty = b.y0 / kTile; ty <= b.y1 / kTile; ++ty)
          for (int tx = b.x0 / kTile; tx <= b.x1 / kTile; ++tx) ++cnt[ty * g.tiles_x + tx];
      }
      using detail::TriClass;
      st.culled_outside = tally[static_cast<int>(TriClass::Outside)];
      st.culled_zero_area = tally[static_cast<int>(TriClass::ZeroArea)];
      st.culled_face = tally[static_cast<int>(TriClass::Face)];
      st.culled_no_pixel = tally[static_cast<int>(TriClass::NoPixel)];
      st.clipped_near = tally[static_cast<int>(TriClass::Clipped)];
      st.rasterized = tally[static_cast<int>(TriClass::Raster)];
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
void fill_bins(const Grid& g, ForwardScratch& sc) {
  parallel_for(0, g.chunks, 1, [&](std::int64_t c0, std::int64_t c1) {
    for (std::int64_t c = c0; c < c1; ++c) {
      std::int32_t* fill = &sc.count[static_cast<std::size_t>(c) * g.tiles];
      std::int32_t* ffill = &sc.fcount[static_cast<std::size_t>(c) * g.tiles];
      for (const detail::Fragment& f : sc.chunk_frag[c]) {
        const int i = f.where / kTilePixels;
        sc.frag[sc.foffset[i] + ffill[i]++] = f;
      }
      for (const std::int32_t t : sc.chunk_binned[c]) {
        const detail::PixelBox& b = sc.box[t];  // binned: not empty
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

// Phase 5: background everywhere (one parallel pass; uv and depth when asked for).
template <class T>
void clear_background(std::int64_t pixels, std::int32_t* tri_id, T* uv, T* depth) {
  parallel_for(0, pixels, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    std::fill(tri_id + lo, tri_id + hi, 0);
    if (uv) std::fill(uv + 2 * lo, uv + 2 * hi, T(0));
    if (depth) std::fill(depth + lo, depth + hi, T(kBackgroundDepth));
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
      scan_tile(*sc.v, p, sc, g.tiles_x, tile, W, H, p.settings.front_to_back, order, *tb);
      const int tx0 = (tile % g.tiles_x) * kTile, ty0 = (tile / g.tiles_x) * kTile;
      const int tw = std::min(kTile, W - tx0), th = std::min(kTile, H - ty0);
      for (int y = 0; y < th; ++y)
        for (int x = 0; x < tw; ++x) {
          const int q = y * kTile + x;
          if (tb->id[q] < 0) continue;
          const std::int64_t px = static_cast<std::int64_t>(ty0 + y) * W + tx0 + x;
          tri_id[px] = tb->id[q] + 1;
          if (uv) {
            uv[2 * px] = saturate<T>(tb->u[q]);
            uv[2 * px + 1] = saturate<T>(tb->v[q]);
          }
          if (depth) depth[px] = saturate<T>(tb->z[q]);
          if (key_depth) key_depth[px] = tb->z[q];
        }
    }
  });
}

}  // namespace

template <class T>
void rasterize_forward(const RasterParams<T>& p, std::int32_t* tri_id, T* uv, T* depth, RasterStats* stats,
                       double* key_depth, std::shared_ptr<const detail::Vertices>* projected) {
  const int W = p.settings.width, H = p.settings.height;
  assert(W >= 1 && H >= 1 && p.num_vertices >= 0 && p.num_tris >= 0);
  auto lease = g_forward_pool.take();
  ForwardScratch& sc = *lease;
  // Phase 1: per-vertex projection (into a pooled Vertices the caller keeps, when asked for).
  if (projected) {
    std::shared_ptr<detail::Vertices> kept = detail::pooled_vertices();
    detail::project_vertices_into(p.clip, p.num_vertices, W, H, kept.get(), p.settings.y_up);
    sc.v = kept.get();
    *projected = std::move(kept);
  } else {
    detail::project_vertices_into(p.clip, p.num_vertices, W, H, &sc.own, p.settings.y_up);
    sc.v = &sc.own;
  }
  const Grid g = make_grid(p.num_tris, W, H);
  const RasterStats st = classify_and_count(p, g, sc);
  if (stats) *stats = st;
  bin_offsets(g, sc);
  fill_bins(g, sc);
  clear_background(static_cast<std::int64_t>(W) * H, tri_id, uv, depth);
  if (key_depth) std::fill(key_depth, key_depth + static_cast<std::int64_t>(W) * H, std::numeric_limits<double>::infinity());
  scan_tiles(p, g, sc, tri_id, uv, depth, key_depth);
}

#define GR_INSTANTIATE(T) \
  template void rasterize_forward<T>(const RasterParams<T>&, std::int32_t*, T*, T*, RasterStats*, double*, \
                                     std::shared_ptr<const detail::Vertices>*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
