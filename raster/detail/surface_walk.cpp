// Surface walk along a screen segment (see surface_walk.h). The silhouette
// criterion is antialias's: raster/antialias.cpp, docs/rasterizer.md.
#include "raster/detail/surface_walk.h"

#include <limits>

namespace gr::raster::detail {
WalkEnd walk_surface(const Vertices& v, const std::int32_t* tris, const EdgeTopology& topology, int width,
                     int height, std::int64_t start, std::int64_t target, double cix, double ciy, double cox,
                     double coy, WalkPath* path, SurfaceSides* sides) {
  std::int64_t cur = start;
  int skip = -1;  // the edge the walk entered through
  if (path) path->count = 1, path->tri[0] = start, path->t[0] = 0.0;
  for (int step = 0; step < kMaxWalk; ++step) {
    const std::int32_t* tri = tris + 3 * cur;
    // det[V1, V2, V0] = det[V0, V1, V2]: one side sign for all three edges.
    int side = sides ? sides->tri(cur) : SurfaceSides::kUnknown;
    if (side == SurfaceSides::kUnknown) {
      side = surface_side(v, tri[1], tri[2], tri[0], width, height);
      if (sides) sides->set_tri(cur, side);
    }
    if (side == 0) return {};
    // The exit: the edge whose value (positive inside) falls to zero first.
    int exit_k = -1;
    double exit_t = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      if (k == skip) continue;
      const std::int32_t a = tri[(k + 1) % 3], b = tri[(k + 2) % 3];
      if (!v.front[a] || !v.front[b]) continue;  // no screen line behind the near plane (skipped, as antialias did)
      const double* sa = &v.screen[3 * static_cast<std::size_t>(a)];
      const double* sb = &v.screen[3 * static_cast<std::size_t>(b)];
      const double ei = side * edge_fn(cix, ciy, sa, sb), eo = side * edge_fn(cox, coy, sa, sb);
      if (!(eo < ei)) continue;
      const double t = ei / (ei - eo);
      if (t < exit_t) exit_k = k, exit_t = t;
    }
    if (exit_k < 0 || !(exit_t < 1.0)) return {WalkEnd::Kind::Continues};
    const std::int32_t a = tri[(exit_k + 1) % 3], b = tri[(exit_k + 2) % 3];
    const std::int64_t nb = topology.neighbour()[3 * cur + exit_k];
    int side_n = 0;
    if (nb >= 0) {
      side_n = sides ? sides->edge(3 * cur + exit_k) : SurfaceSides::kUnknown;
      if (side_n == SurfaceSides::kUnknown) {
        side_n = surface_side(v, a, b, tris[nb], width, height);  // tris[3n + k'] = opposite vertex
        if (sides) sides->set_edge(3 * cur + exit_k, side_n);
      }
    }
    if (nb < 0 || side_n == 0 || side_n == side)
      return {WalkEnd::Kind::Silhouette, a, b, exit_t > 0.0 ? exit_t : 0.0};  // t < 0: rounding at a centre on the edge
    cur = nb / 3;
    skip = static_cast<int>(nb % 3);
    if (cur == target) return {WalkEnd::Kind::Reached};
    if (path) path->tri[path->count] = cur, path->t[path->count] = exit_t, ++path->count;
  }
  return {};
}

}  // namespace gr::raster::detail
