// walk_surface (raster/detail/surface_walk.cpp) expression for expression, for
// the pairs passes of antialias and visibility_antialias: from a triangle
// covering centre ci, cross interior edges towards centre co until the surface
// ends at a silhouette edge, reaches `target`, or still goes on at co. Needs
// antialias_common.glsl and the `tris` and `neighbour` buffers.

const int kMaxWalk = 16;  // interior edges crossed at most (surface_walk.h)

// WalkEnd::Kind.
const int kSilhouette = 0, kReached = 1, kContinues = 2, kLost = 3;
struct WalkEnd {
  int kind;
  int a, b;  // kSilhouette: the edge's vertices
  double t;  // kSilhouette: crossing position in [0, 1)
};

// WalkPath: the triangles passed, tri[i] from t[i] (t[0] = 0) on.
struct WalkPath {
  int count;
  int tri[kMaxWalk + 1];
  double t[kMaxWalk + 1];
};

// Side of the line a-b on which the triangle a, b, o lies: -sign det[Va, Vb, Vo].
int surface_side(int a, int b, int o) {
  double d = hdot(hcross(homogeneous(a), homogeneous(b)), homogeneous(o));
  return d > 0.0 ? -1 : (d < 0.0 ? 1 : 0);
}

WalkEnd walk_surface(int start, int target, dvec2 ci, dvec2 co, inout WalkPath path) {
  const double inf = packDouble2x32(uvec2(0u, 0x7ff00000u));
  WalkEnd lost = WalkEnd(kLost, -1, -1, 0.0);
  int cur = start, skip = -1;  // skip: the edge the walk entered through
  path.count = 1;
  path.tri[0] = start;
  path.t[0] = 0.0;
  for (int step = 0; step < kMaxWalk; ++step) {
    int tri[3] = int[3](tris[3 * cur], tris[3 * cur + 1], tris[3 * cur + 2]);
    int side = surface_side(tri[1], tri[2], tri[0]);
    if (side == 0) return lost;
    // The exit: the edge whose value (positive inside) falls to zero first.
    int exit_k = -1;
    double exit_t = inf;
    for (int k = 0; k < 3; ++k) {
      int a = tri[(k + 1) % 3], b = tri[(k + 2) % 3];
      if (k == skip || !in_front(a) || !in_front(b)) continue;
      dvec2 sa = screen_of(a), sb = screen_of(b);
      precise double ei = double(side) * edge_fn(ci, sa, sb);
      precise double eo = double(side) * edge_fn(co, sa, sb);
      if (!(eo < ei)) continue;
      precise double d = ei - eo;
      double t = div_rn(ei, d);
      if (t < exit_t) {
        exit_k = k;
        exit_t = t;
      }
    }
    if (exit_k < 0 || !(exit_t < 1.0)) return WalkEnd(kContinues, -1, -1, 0.0);
    int a = tri[(exit_k + 1) % 3], b = tri[(exit_k + 2) % 3];
    int nb = neighbour[3 * cur + exit_k];
    int side_n = nb >= 0 ? surface_side(a, b, tris[nb]) : 0;  // tris[3n + k'] = the opposite vertex
    if (nb < 0 || side_n == 0 || side_n == side) return WalkEnd(kSilhouette, a, b, exit_t > 0.0 ? exit_t : 0.0);
    cur = nb / 3;
    skip = nb % 3;
    if (cur == target) return WalkEnd(kReached, -1, -1, 0.0);
    path.tri[path.count] = cur;
    path.t[path.count] = exit_t;
    ++path.count;
  }
  return lost;
}

// pair_owns_direction: horizontal pairs own boundaries with |dy| >= |dx|, vertical ones |dx| > |dy|.
bool pair_owns_direction(bool horizontal, double dx, double dy) {
  double ax = abs(dx), ay = abs(dy);
  return horizontal ? ay >= ax : ax > ay;
}
