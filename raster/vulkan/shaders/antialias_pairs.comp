#version 460
// Per pixel p: its pairs with the right and the lower neighbour (slots 2p,
// 2p + 1), evaluated as antialias_forward does (raster/antialias.cpp): when
// the triangle ids differ, walk from the front triangle's centre towards the
// other centre across interior edges (walk_surface, raster/detail/surface_walk.cpp);
// a silhouette crossed before it, owned by the pair's axis, blends.
#include "dispatch.glsl"
#include "antialias_common.glsl"

layout(std430, binding = 1) readonly buffer TriBuf { int tris[]; };
layout(std430, binding = 3) readonly buffer TriIdBuf { int tri_id[]; };
// The G-buffer (u, v, z/w, id per pixel): the depth is z/w, as the CPU ops pass it.
layout(std430, binding = 4) readonly buffer RastBuf { float rast[]; };
float depth(int p) { return rast[4 * p + 2]; }
// EdgeTopology::neighbour (3 per triangle: 3n + k', or < 0).
layout(std430, binding = 5) readonly buffer NeighbourBuf { int neighbour[]; };
layout(std430, binding = 7) writeonly buffer PairBuf { Pair pairs[]; };

const int kMaxWalk = 16;  // interior edges crossed at most (surface_walk.h)

// Side of the line a-b on which the triangle a, b, o lies: -sign det[Va, Vb, Vo].
int surface_side(int a, int b, int o) {
  double d = hdot(hcross(homogeneous(a), homogeneous(b)), homogeneous(o));
  return d > 0.0 ? -1 : (d < 0.0 ? 1 : 0);
}

// walk_surface with no target: the silhouette edge (a, b) and t, or a < 0.
Pair walk(int start, dvec2 ci, dvec2 co) {
  Pair none = Pair(0.0, -1, 0);
  const double inf = packDouble2x32(uvec2(0u, 0x7ff00000u));
  int cur = start, skip = -1;
  for (int step = 0; step < kMaxWalk; ++step) {
    int tri[3] = int[3](tris[3 * cur], tris[3 * cur + 1], tris[3 * cur + 2]);
    int side = surface_side(tri[1], tri[2], tri[0]);
    if (side == 0) return none;
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
    if (exit_k < 0 || !(exit_t < 1.0)) return none;
    int a = tri[(exit_k + 1) % 3], b = tri[(exit_k + 2) % 3];
    int nb = neighbour[3 * cur + exit_k];
    int side_n = nb >= 0 ? surface_side(a, b, tris[nb]) : 0;  // tris[3n + k'] = the opposite vertex
    if (nb < 0 || side_n == 0 || side_n == side) return Pair(exit_t > 0.0 ? exit_t : 0.0, a, b);
    cur = nb / 3;
    skip = nb % 3;
  }
  return none;
}

// The pair (p, q): front pixel by the (depth, id) key, background behind all.
Pair evaluate(int p, int q, bool horizontal) {
  Pair none = Pair(0.0, -1, 0);
  int ip = tri_id[p], iq = tri_id[q];
  if (ip == iq) return none;
  bool p_front = iq == 0 || (ip != 0 && (depth(p) < depth(q) || (depth(p) == depth(q) && ip < iq)));
  int inside = p_front ? p : q, outside = p_front ? q : p;
  Pair e = walk((p_front ? ip : iq) - 1, centre(inside), centre(outside));
  if (e.a < 0) return none;
  // pair_owns_direction: horizontal pairs own |dy| >= |dx|, vertical |dx| > |dy|.
  dvec2 sa = screen_of(e.a), sb = screen_of(e.b);
  precise double dx = abs(sb.x - sa.x);
  precise double dy = abs(sb.y - sa.y);
  if (!(horizontal ? dy >= dx : dx > dy)) return none;
  if (!p_front) e.b |= int(0x80000000u);
  return e;
}

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int x = p % P.width, y = p / P.width;
  Pair none = Pair(0.0, -1, 0);
  pairs[2 * p] = x + 1 < P.width ? evaluate(p, p + 1, true) : none;
  pairs[2 * p + 1] = y + 1 < P.height ? evaluate(p, p + P.width, false) : none;
}
