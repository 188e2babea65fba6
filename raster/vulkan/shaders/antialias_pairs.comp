#version 460
// Per pixel p: its pairs with the right and the lower neighbour (slots 2p,
// 2p + 1), evaluated as antialias_forward does (raster/antialias.cpp): when
// the triangle ids differ, walk from the front triangle's centre towards the
// other centre across interior edges (walk_surface, surface_walk.glsl);
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

#include "surface_walk.glsl"

// The pair (p, q): front pixel by the (depth, id) key, background behind all
// (offsetting the ids keeps their order).
Pair evaluate(int p, int q, bool horizontal) {
  Pair none = Pair(0.0, -1, 0);
  int ip = tri_id[p], iq = tri_id[q];
  if (ip == iq) return none;
  bool p_front = iq == 0 || (ip != 0 && (depth(p) < depth(q) || (depth(p) == depth(q) && ip < iq)));
  int inside = p_front ? p : q, outside = p_front ? q : p;
  WalkPath path;
  WalkEnd e = walk_surface(triangle_of(p_front ? ip : iq), triangle_of(p_front ? iq : ip), centre(inside),
                           centre(outside), path);
  if (e.kind != kSilhouette) return none;
  dvec2 sa = screen_of(e.a), sb = screen_of(e.b);
  if (!pair_owns_direction(horizontal, sb.x - sa.x, sb.y - sa.y)) return none;
  Pair pr = Pair(e.t, e.a, e.b);
  if (!p_front) pr.b |= int(0x80000000u);
  return pr;
}

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int x = p % P.width, y = p / P.width;
  Pair none = Pair(0.0, -1, 0);
  pairs[2 * p] = x + 1 < P.width ? evaluate(p, p + 1, true) : none;
  pairs[2 * p + 1] = y + 1 < P.height ? evaluate(p, p + P.width, false) : none;
}
