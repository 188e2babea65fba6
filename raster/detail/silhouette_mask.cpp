// The antialias walk's prefilter (see silhouette_mask.h).
#include "raster/detail/silhouette_mask.h"

#include <algorithm>
#include <cmath>

#include "autodiff/base/parallel.h"

namespace gr::raster::detail {

std::atomic<SilhouettePrefilter> g_silhouette_prefilter{SilhouettePrefilter::Auto};
std::atomic<std::int64_t> g_prefilter_skipped_walks{0};

namespace {

// Marks the pixels whose square [x, x + 1] x [y, y + 1], grown by m, touches
// the screen segment a-b: per pixel row, the part of the segment inside the
// row's grown band spans [xlo, xhi]; columns whose grown square meets it.
void mark_segment(const double* a, const double* b, int W, int H, std::vector<std::atomic<std::uint8_t>>& mask) {
  const double m = kSilhouetteMargin;
  double x0 = a[0], y0 = a[1], x1 = b[0], y1 = b[1];
  if (y0 > y1) std::swap(x0, x1), std::swap(y0, y1);
  // Rows y with y - m <= y1 and y + 1 + m >= y0, inside the image.
  const double rlo = std::max(std::ceil(y0 - 1.0 - m), 0.0), rhi = std::min(std::floor(y1 + m), double(H - 1));
  if (!(rlo <= rhi)) return;
  const double dy = y1 - y0;
  for (std::int64_t y = static_cast<std::int64_t>(rlo); y <= static_cast<std::int64_t>(rhi); ++y) {
    const double ya = std::max(double(y) - m, y0), yb = std::min(double(y) + 1.0 + m, y1);
    double xa = x0, xb = x1;
    if (dy > 0.0) {
      const double ua = std::clamp((ya - y0) / dy, 0.0, 1.0), ub = std::clamp((yb - y0) / dy, 0.0, 1.0);
      xa = x0 + ua * (x1 - x0);
      xb = x0 + ub * (x1 - x0);
    }
    const double xlo = std::min(xa, xb), xhi = std::max(xa, xb);
    const double clo = std::max(std::ceil(xlo - 1.0 - m), 0.0), chi = std::min(std::floor(xhi + m), double(W - 1));
    if (!(clo <= chi)) continue;
    std::atomic<std::uint8_t>* row = mask.data() + y * W;
    for (std::int64_t x = static_cast<std::int64_t>(clo); x <= static_cast<std::int64_t>(chi); ++x)
      row[x].store(1, std::memory_order_relaxed);
  }
}

// det[Va, Vb, Vo] as surface_side computes it, and the sum of the absolute
// values of its six products: any evaluation order of the determinant (a
// rotation of a, b, o) is within kVolumeTolerance / 2 of that sum of the exact
// value (two roundings per product, cross difference, dot: 4 units of
// 2^-53 each, doubled for slack), so a value beyond the tolerance has the
// exact sign and every rotation's computed sign with it.
struct SignedVolume {
  double value, bound;
};
constexpr double kVolumeTolerance = 16.0 * 0x1p-53;
constexpr double kSmallestBound = 0x1p-900;
SignedVolume signed_volume(const Vertices& v, std::int32_t a, std::int32_t b, std::int32_t o, int w, int h) {
  const HVec A = homogeneous(v, a, w, h), B = homogeneous(v, b, w, h), O = homogeneous(v, o, w, h);
  const double value = dot(cross(A, B), O);
  const double bound = (std::abs(A.y * B.w) + std::abs(A.w * B.y)) * std::abs(O.x) +
                       (std::abs(A.w * B.x) + std::abs(A.x * B.w)) * std::abs(O.y) +
                       (std::abs(A.x * B.y) + std::abs(A.y * B.x)) * std::abs(O.w);
  return {value, bound};
}

// Screen coordinates within 2^36 px of the origin: there the walk's edge
// values place a point to about 2^36 * 2^-52 = 2^-16 px, well inside the
// margin; a vertex beyond (w near 0) could round the exit point off its edge.
// (Checked per vertex in front: a triangle with another is refused anyway.)
constexpr double kMaxScreen = 0x1p36;
bool all_on_sane_screen(const Vertices& v) {
  const std::int64_t n = static_cast<std::int64_t>(v.front.size());
  std::atomic<bool> off{false};
  parallel_for(0, n, 8192, [&](std::int64_t lo, std::int64_t hi) {
    bool bad = false;
    for (std::int64_t i = lo; i < hi; ++i) {
      const double* s = &v.screen[3 * static_cast<std::size_t>(i)];
      bad |= v.front[i] && !(std::abs(s[0]) <= kMaxScreen && std::abs(s[1]) <= kMaxScreen);
    }
    if (bad) off.store(true, std::memory_order_relaxed);
  });
  return !off.load();
}

bool same_screen_point(const Vertices& v, std::int32_t i, std::int32_t j) {
  return i == j || (v.screen[3 * static_cast<std::size_t>(i)] == v.screen[3 * static_cast<std::size_t>(j)] &&
                    v.screen[3 * static_cast<std::size_t>(i) + 1] == v.screen[3 * static_cast<std::size_t>(j) + 1]);
}

}  // namespace

std::int64_t count_id_boundaries(const std::int32_t* tri_id, std::int64_t W, std::int64_t H) {
  std::vector<std::vector<char>> none;  // for_each_id_boundary's count, nothing evaluated
  return for_each_id_boundary(tri_id, W, H, none, [](std::int64_t, std::int64_t, bool, std::vector<char>&) {});
}

// The half-edge pass costs about 220 instructions per triangle and saves
// about 270 per candidate pair (most of a walk); break-even measured at 0.8
// pairs per triangle (the fit at 32 to 256 px, docs/performance.md).
bool prefilter_pays(std::int64_t candidates, std::int64_t num_tris) { return candidates >= num_tris; }

bool build_silhouette_mask(const Vertices& v, const std::int32_t* tris, std::int64_t num_tris,
                           const EdgeTopology& topology, int W, int H, SurfaceSides& sides,
                           std::vector<std::atomic<std::uint8_t>>& mask) {
  if (!all_on_sane_screen(v)) return false;
  std::atomic<bool> refused{false};
  // 1. Per triangle: its side (walk_surface's expression, into the memo) and
  // that side's sign where rounding cannot flip it (0 where it could).
  std::vector<std::int8_t> certain(static_cast<std::size_t>(num_tris));
  parallel_for(0, num_tris, 2048, [&](std::int64_t t0, std::int64_t t1) {
    if (refused.load(std::memory_order_relaxed)) return;
    for (std::int64_t t = t0; t < t1; ++t) {
      const std::int32_t* tri = tris + 3 * t;
      if (needs_clipping(v, tri)) {
        refused.store(true, std::memory_order_relaxed);
        return;
      }
      const SignedVolume d = signed_volume(v, tri[1], tri[2], tri[0], W, H);
      const int side = d.value > 0.0 ? -1 : (d.value < 0.0 ? 1 : 0);  // = surface_side(v, tri[1], tri[2], tri[0], W, H)
      sides.set_tri(t, side);
      // Products near underflow round absolutely, not relatively: uncertain.
      const bool sure = std::abs(d.value) > kVolumeTolerance * d.bound && d.bound > kSmallestBound;
      certain[t] = static_cast<std::int8_t>(sure ? side : 0);
    }
  });
  if (refused.load()) return false;
  // 2. Per half-edge of a triangle with a side: walk_surface's silhouette test,
  // from the neighbour's certain side where the edge is the same vertex pair
  // (det[Va, Vb, Vo] is +-det of the neighbour's own rotation), else computed.
  const std::int64_t* neighbour = topology.neighbour().data();
  constexpr int kNext[3] = {1, 2, 0}, kPrev[3] = {2, 0, 1};
  parallel_for(0, num_tris, 2048, [&](std::int64_t t0, std::int64_t t1) {
    if (refused.load(std::memory_order_relaxed)) return;
    for (std::int64_t t = t0; t < t1; ++t) {
      const int side = sides.tri(t);
      if (side == 0) continue;  // a walk in t ends "Lost" before any edge
      const std::int32_t* tri = tris + 3 * t;
      for (int k = 0; k < 3; ++k) {
        const std::int32_t a = tri[kNext[k]], b = tri[kPrev[k]];
        const std::int64_t nb = neighbour[3 * t + k];
        bool silhouette = nb < 0;
        if (!silhouette) {
          const std::int64_t n = nb / 3;
          const int kn = static_cast<int>(nb - 3 * n);
          const std::int32_t na = tris[3 * n + kNext[kn]], nb_end = tris[3 * n + kPrev[kn]];
          if ((na == b && nb_end == a) || (na == a && nb_end == b)) {
            // side_n = -sign det[Va, Vb, Vo] = side(n) when n runs a -> b, -side(n) when b -> a.
            const int sn = certain[n];
            silhouette = sn == 0 || (na == a ? sn : -sn) == side;
          } else {
            const bool shared = (same_screen_point(v, na, b) && same_screen_point(v, nb_end, a)) ||
                                (same_screen_point(v, na, a) && same_screen_point(v, nb_end, b));
            if (!shared) {
              refused.store(true, std::memory_order_relaxed);
              return;
            }
            int side_n = sides.edge(3 * t + k);
            if (side_n == SurfaceSides::kUnknown) {
              side_n = surface_side(v, a, b, tris[nb], W, H);
              sides.set_edge(3 * t + k, side_n);
            }
            silhouette = side_n == 0 || side_n == side;
          }
        }
        if (!silhouette) continue;
        mark_segment(&v.screen[3 * static_cast<std::size_t>(a)], &v.screen[3 * static_cast<std::size_t>(b)], W, H,
                     mask);
      }
    }
  });
  return !refused.load();
}

}  // namespace gr::raster::detail
