// Following a mesh surface along a screen segment (used by antialias and
// visibility_antialias, raster/antialias.h, raster/visibility_antialias.h): starting in a triangle at
// one pixel centre, cross interior edges towards the other centre until the
// surface ends at a silhouette edge, reaches a given triangle, or still goes
// on at the other centre. Internal to raster/.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/antialias.h"
#include "raster/detail/rasterize_setup.h"

namespace gr::raster::detail {

// Screen edge function E(q; a, b) = (qx - ax)(by - ay) - (qy - ay)(bx - ax).
inline double edge_fn(double qx, double qy, const double* a, const double* b) {
  return (qx - a[0]) * (b[1] - a[1]) - (qy - a[1]) * (b[0] - a[0]);
}

// A boundary line with screen direction (dx, dy) belongs to the horizontal
// pairs when it is closer to vertical (|dy| >= |dx|, ties included), else to
// the vertical pairs, so each crossing is blended once (raster/antialias.cpp).
inline bool pair_owns_direction(bool horizontal, double dx, double dy) {
  dx = dx < 0 ? -dx : dx;
  dy = dy < 0 ? -dy : dy;
  return horizontal ? dy >= dx : dx > dy;
}

// Calls evaluate(p, q, horizontal, rows[y]) for every pair of neighbouring
// pixels p (row y) and q = its right (horizontal) or lower neighbour whose
// triangle ids differ, rows in parallel; evaluate may append pairs to the
// row's list. Returns how many such pairs there were.
template <class Pair, class Evaluate>
std::int64_t for_each_id_boundary(const std::int32_t* tri_id, std::int64_t W, std::int64_t H,
                                  std::vector<std::vector<Pair>>& rows, Evaluate evaluate) {
  rows.assign(static_cast<std::size_t>(H), {});
  std::vector<std::int64_t> candidates(static_cast<std::size_t>(H), 0);
  parallel_for(0, H, 4, [&](std::int64_t y0, std::int64_t y1) {
    for (std::int64_t y = y0; y < y1; ++y) {
      const std::int32_t* row = tri_id + y * W;
      std::int64_t count = 0;
      for (std::int64_t x = 0; x < W; ++x) {
        const std::int64_t p = y * W + x;
        if (x + 1 < W && row[x] != row[x + 1]) {
          ++count;
          evaluate(p, p + 1, true, rows[y]);
        }
        if (y + 1 < H && row[x] != row[x + W]) {
          ++count;
          evaluate(p, p + W, false, rows[y]);
        }
      }
      candidates[y] = count;
    }
  });
  std::int64_t total = 0;
  for (const std::int64_t c : candidates) total += c;
  return total;
}

// The one-sided blend of a pair whose boundary crosses the segment from the
// inside centre to the outside centre at t: the pixel on the far side of
// t = 1/2 (target) takes weight w = |t - 1/2| of the other's colour (source).
struct BlendStep {
  std::int64_t target, source;
  double w;
};
template <class Pair>
BlendStep blend_step(const Pair& pr) {
  const bool outward = pr.t > 0.5;
  return {outward ? pr.outside : pr.inside, outward ? pr.inside : pr.outside, outward ? pr.t - 0.5 : 0.5 - pr.t};
}

// out[target] += w (image[source] - image[target]), C channels.
template <class T>
void apply_blend(const BlendStep& b, const T* image, T* out, int C) {
  for (int c = 0; c < C; ++c) {
    const double d = double(image[b.source * C + c]) - double(image[b.target * C + c]);
    out[b.target * C + c] = static_cast<T>(double(out[b.target * C + c]) + b.w * d);
  }
}

// The blends' adjoint to the image (P pixels, C channels): the identity plus,
// in pair order, -w g[target] to the target and +w g[target] to the source.
template <class T, class Pair>
void blend_image_adjoint(const std::vector<Pair>& pairs, const T* grad_out, T* grad_image, std::int64_t P, int C) {
  parallel_for(0, P * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) grad_image[i] += grad_out[i];
  });
  for (const Pair& pr : pairs) {
    const BlendStep b = blend_step(pr);
    for (int c = 0; c < C; ++c) {
      const double g = double(grad_out[b.target * C + c]);
      if (g == 0.0) continue;
      grad_image[b.target * C + c] -= static_cast<T>(b.w * g);
      grad_image[b.source * C + c] += static_cast<T>(b.w * g);
    }
  }
}

// Interior edges crossed at most between two pixel centres.
constexpr int kMaxWalk = 16;

// The triangles a walk passed through: tri[i] from t[i] (t[0] = 0) to t[i + 1]
// (or to the end of the walk), along the segment from ci to co.
struct WalkPath {
  int count = 0;
  std::int64_t tri[kMaxWalk + 1];
  double t[kMaxWalk + 1];
};

struct WalkEnd {
  enum class Kind { Silhouette, Reached, Continues, Lost };
  Kind kind = Kind::Lost;
  std::int32_t a = -1, b = -1;  // Silhouette: the edge's vertices
  double t = 0;                 // Silhouette: crossing position in [0, 1)
};

// Side of the line a-b (screen) on which the surface of the triangle through
// a, b and o lies near the edge: the sign of E(.; a, b) there, computed in
// homogeneous coordinates (-sign det[Va, Vb, Vo]); 0 if degenerate. The walk
// and the silhouette prefilter (raster/detail/silhouette_mask.h) share it.
inline int surface_side(const Vertices& v, std::int32_t a, std::int32_t b, std::int32_t o, int w, int h) {
  const double d = dot(cross(homogeneous(v, a, w, h), homogeneous(v, b, w, h)), homogeneous(v, o, w, h));
  return d > 0.0 ? -1 : (d < 0.0 ? 1 : 0);
}

// The surface sides a walk computes, memoized for one call's vertices and
// triangles: per triangle (det[V1, V2, V0]) and per edge 3t + k (the
// neighbour's side of t's edge k). Walks along a long edge cross it again and
// again (issue 31); each side is computed once, on first use, by whichever
// thread asks first (antialias's prefilter, raster/detail/silhouette_mask.h,
// stores every triangle's side before the walks, by the same expression). Relaxed atomics suffice: every thread computes the same
// value with the same expression, so the results are those of no memo.
class SurfaceSides {
 public:
  explicit SurfaceSides(std::int64_t num_tris)
      : tri_(static_cast<std::size_t>(num_tris)), edge_(3 * static_cast<std::size_t>(num_tris)) {}
  // side in {-1, 0, 1}; kUnknown until stored.
  static constexpr int kUnknown = 2;
  int tri(std::int64_t t) const { return load(tri_[t]); }
  int edge(std::int64_t e) const { return load(edge_[e]); }
  void set_tri(std::int64_t t, int side) { store(tri_[t], side); }
  void set_edge(std::int64_t e, int side) { store(edge_[e], side); }

 private:
  // Stored as side + 2 (0: unknown, the value-initialized state).
  static int load(const std::atomic<std::int8_t>& a) {
    const int s = a.load(std::memory_order_relaxed);
    return s == 0 ? kUnknown : s - 2;
  }
  static void store(std::atomic<std::int8_t>& a, int side) {
    a.store(static_cast<std::int8_t>(side + 2), std::memory_order_relaxed);
  }
  std::vector<std::atomic<std::int8_t>> tri_, edge_;
};

// Walk from triangle `start` (covering centre ci) towards centre co:
//   Silhouette  the surface ends at edge a-b (boundary, non-manifold, or the
//               neighbour folds onto the same screen side) at t < 1;
//   Reached     it entered triangle `target` (the same surface);
//   Continues   the other centre is still on it, in another triangle;
//   Lost        degenerate triangle or too many steps.
// Edges with a vertex behind the near plane have no screen line and are
// skipped (the segment is taken to leave through another edge).
// If `path` is given it receives the triangles passed through. `sides`, if
// given, must have been made for these vertices and triangles (it changes no
// result, only how often a side is computed).
WalkEnd walk_surface(const Vertices& v, const std::int32_t* tris, const EdgeTopology& topology, int width,
                     int height, std::int64_t start, std::int64_t target, double cix, double ciy, double cox,
                     double coy, WalkPath* path = nullptr, SurfaceSides* sides = nullptr);

}  // namespace gr::raster::detail
