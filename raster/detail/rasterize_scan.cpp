// The per-tile scan of one triangle (see rasterize_scan.h). SSE2 when the
// compiler targets it (every x86-64), else the same expressions one pixel at
// a time; both give the same bits.
#include "raster/detail/rasterize_scan.h"

#include <algorithm>

// GR_SCAN_SCALAR forces the portable loop (to check that it gives the same bits).
#if defined(__SSE2__) && !defined(GR_SCAN_SCALAR)
#define GR_SCAN_SSE2 1
#include <emmintrin.h>
#endif

namespace gr::raster::detail {
namespace {

// Boxes (clipped to the tile) of at most this many pixels take the scalar loop.
constexpr int kSmallBox = 4;

// e > 0, or e == 0 on a top-left edge (tie); NaN is outside.
#if defined(GR_SCAN_SSE2)
template <bool Tie>
inline __m128d inside2(__m128d e) {
  return Tie ? _mm_cmpge_pd(e, _mm_setzero_pd()) : _mm_cmpgt_pd(e, _mm_setzero_pd());
}
#endif

// Depth range test, the peeling floor, then the (depth, id) key test; the winner's values go to slot p.
inline void resolve_pixel(const TriSetup& s, std::int32_t t, int p, double z, double u, double v, TileBuffer& tb) {
  if (s.z_test && !(z >= -1.0 && z <= 1.0)) return;
  if (tb.floor && !(z > tb.fz[p] || (z == tb.fz[p] && t > tb.fid[p]))) return;
  if (z < tb.z[p] || (z == tb.z[p] && t < tb.id[p])) {
    tb.covered += tb.id[p] < 0;
    tb.z[p] = z;
    tb.id[p] = t;
    tb.u[p] = u;
    tb.v[p] = v;
  }
}

// Rows y0..y1 of the column range x0..x0+n-1 (n <= kTile) of one triangle.
// col[k][i] = (px_i - ax_k) dy_k is shared by every row; per row the edge
// values ((col - (py - ay) dx) + c) and their coverage are computed two pixels
// at a time, then depth and (u, v) only for covered pixels.
template <bool T0, bool T1, bool T2>
void scan_rows(const TriSetup& s, std::int32_t t, int x0, int n, int y0, int y1, int tx0, int ty0,
               TileBuffer& tb) {
  const Edge* e = s.e;
  const std::uint32_t valid = n >= 32 ? ~std::uint32_t(0) : (std::uint32_t(1) << n) - 1;
  alignas(16) double col[3][kTile];
  alignas(16) double ev[3][kTile];
  const int pairs = (n + 1) >> 1;  // kTile is even, so the padded pair stays in the arrays
#if defined(GR_SCAN_SSE2)
  for (int k = 0; k < 3; ++k) {
    const __m128d ax = _mm_set1_pd(e[k].ax), dy = _mm_set1_pd(e[k].dy), two = _mm_set1_pd(2.0);
    __m128d px = _mm_set_pd(x0 + 1.5, x0 + 0.5);  // exact: x + 0.5 for integer x
    for (int j = 0; j < pairs; ++j) {
      _mm_store_pd(&col[k][2 * j], _mm_mul_pd(_mm_sub_pd(px, ax), dy));
      px = _mm_add_pd(px, two);
    }
  }
  const __m128d c0 = _mm_set1_pd(e[0].c), c1 = _mm_set1_pd(e[1].c), c2 = _mm_set1_pd(e[2].c);
#else
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 2 * pairs; ++i) col[k][i] = ((x0 + i) + 0.5 - e[k].ax) * e[k].dy;
#endif
  const double mz0 = e[0].mz, mz1 = e[1].mz, mz2 = e[2].mz, mu1 = e[1].mu, mu2 = e[2].mu;
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    const double r0 = e[0].row(py), r1 = e[1].row(py), r2 = e[2].row(py);
    std::uint32_t mask = 0;
#if defined(GR_SCAN_SSE2)
    const __m128d rr0 = _mm_set1_pd(r0), rr1 = _mm_set1_pd(r1), rr2 = _mm_set1_pd(r2);
    for (int j = 0; j < pairs; ++j) {
      const int i = 2 * j;
      const __m128d v0 = _mm_add_pd(_mm_sub_pd(_mm_load_pd(&col[0][i]), rr0), c0);
      const __m128d v1 = _mm_add_pd(_mm_sub_pd(_mm_load_pd(&col[1][i]), rr1), c1);
      const __m128d v2 = _mm_add_pd(_mm_sub_pd(_mm_load_pd(&col[2][i]), rr2), c2);
      _mm_store_pd(&ev[0][i], v0);
      _mm_store_pd(&ev[1][i], v1);
      _mm_store_pd(&ev[2][i], v2);
      const __m128d in = _mm_and_pd(_mm_and_pd(inside2<T0>(v0), inside2<T1>(v1)), inside2<T2>(v2));
      mask |= static_cast<std::uint32_t>(_mm_movemask_pd(in)) << i;
    }
#else
    const double r[3] = {r0, r1, r2};
    for (int i = 0; i < 2 * pairs; ++i) {
      bool in = true;
      for (int k = 0; k < 3; ++k) {
        ev[k][i] = (col[k][i] - r[k]) + e[k].c;
        in = in && e[k].inside(ev[k][i]);
      }
      mask |= static_cast<std::uint32_t>(in) << i;
    }
#endif
    mask &= valid;
    const int row = (y - ty0) * kTile + (x0 - tx0);
    while (mask) {
      const int i = __builtin_ctz(mask);
      mask &= mask - 1;
      const double z = ev[0][i] * mz0 + ev[1][i] * mz1 + ev[2][i] * mz2;
      resolve_pixel(s, t, row + i, z, ev[1][i] * mu1, ev[2][i] * mu2, tb);
    }
  }
}

// The same scan one pixel at a time, for boxes of a few pixels (where the
// vector loop's per-triangle and per-row work does not pay off).
void scan_small(const TriSetup& s, std::int32_t t, int x0, int x1, int y0, int y1, int tx0, int ty0,
                TileBuffer& tb) {
  const Edge &e0 = s.e[0], &e1 = s.e[1], &e2 = s.e[2];
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    const double r0 = e0.row(py), r1 = e1.row(py), r2 = e2.row(py);
    const int row = (y - ty0) * kTile - tx0;
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5;
      const double v0 = e0.eval(px, r0), v1 = e1.eval(px, r1), v2 = e2.eval(px, r2);
      if (!(e0.inside(v0) & e1.inside(v1) & e2.inside(v2))) continue;
      resolve_pixel(s, t, row + x, v0 * e0.mz + v1 * e1.mz + v2 * e2.mz, v1 * e1.mu, v2 * e2.mu, tb);
    }
  }
}

}  // namespace

void resolve_fragments(const Fragment* f, std::int64_t n, TileBuffer& tb) {
  for (std::int64_t i = 0; i < n; ++i) {
    const int p = f[i].where % kTilePixels;
    const double z = f[i].z;
    const std::int32_t t = f[i].id;
    if (tb.floor && !(z > tb.fz[p] || (z == tb.fz[p] && t > tb.fid[p]))) continue;
    if (z < tb.z[p] || (z == tb.z[p] && t < tb.id[p])) {
      tb.covered += tb.id[p] < 0;
      tb.z[p] = z;
      tb.id[p] = t;
      tb.u[p] = f[i].u;
      tb.v[p] = f[i].v;
    }
  }
}

void scan_triangle(const Vertices& v, const std::int32_t* tris, std::int32_t t, const PixelBox& b,
                   int tx0, int ty0, int tx1, int ty1, int width, int height, TileBuffer& tb) {
  const int x0 = std::max(b.x0, tx0), x1 = std::min(b.x1, tx1);
  const int y0 = std::max(b.y0, ty0), y1 = std::min(b.y1, ty1);
  if (x0 > x1 || y0 > y1) return;
  TriSetup s;
  setup_edges(v, tris + 3 * static_cast<std::int64_t>(t), width, height, &s);
  const int n = x1 - x0 + 1;
  if (n * (y1 - y0 + 1) <= kSmallBox) {
    scan_small(s, t, x0, x1, y0, y1, tx0, ty0, tb);
    return;
  }
  // The top-left flags select the coverage comparison at compile time.
  switch (s.e[0].tie | s.e[1].tie << 1 | s.e[2].tie << 2) {
    case 0: scan_rows<false, false, false>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    case 1: scan_rows<true, false, false>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    case 2: scan_rows<false, true, false>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    case 3: scan_rows<true, true, false>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    case 4: scan_rows<false, false, true>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    case 5: scan_rows<true, false, true>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    case 6: scan_rows<false, true, true>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
    default: scan_rows<true, true, true>(s, t, x0, n, y0, y1, tx0, ty0, tb); break;
  }
}

}  // namespace gr::raster::detail
