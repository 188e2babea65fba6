#version 460
// antialias_pairs.comp for visibility_antialias_forward
// (raster/visibility_antialias.cpp), slot for slot: per pixel p, its pairs
// with the right and the lower neighbour, when the triangle ids differ:
//   1. walk the front surface (smaller (depth, id)) towards the other centre:
//      a silhouette is the boundary; reaching the other triangle, none;
//   2. if it goes on, hidden, walk the other surface back: a silhouette is
//      the boundary (the occluder's, inside = the back pixel);
//   3. if both go on, the first piece of the two walks' paths where
//      d = z_F - z_B goes from <= 0 to >= 0 is the crossing,
//      t = d0 / (d0 - d1) with the planes of the triangles there.
// Edges are stored as antialias's; crossings with kCrossingBit and the two
// triangles (antialias_common.glsl).
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
#include "depth_plane.glsl"

// kMinDepthStep and kDepthTie (raster/visibility_antialias.cpp).
const double kMinDepthStep = 1e-12;
const double kDepthTie = 1e-12;

const Pair kNone = Pair(0.0, -1, 0);

bool all_front(int t) { return in_front(tris[3 * t]) && in_front(tris[3 * t + 1]) && in_front(tris[3 * t + 2]); }

// A silhouette edge as the boundary: the pair's axis must own it.
Pair edge_pair(WalkEnd e, bool horizontal, bool inside_second) {
  dvec2 sa = screen_of(e.a), sb = screen_of(e.b);
  if (!pair_owns_direction(horizontal, sb.x - sa.x, sb.y - sa.y)) return kNone;
  Pair pr = Pair(e.t, e.a, e.b);
  if (inside_second) pr.b |= int(0x80000000u);
  return pr;
}

// first_crossing: the two paths (pf from fc, pb from bc) piece by piece.
Pair crossing_pair(WalkPath pf, WalkPath pb, dvec2 fc, dvec2 bc, bool horizontal, bool inside_second) {
  int i = 0, j = pb.count - 1;  // the other path covers t near 0 with its last triangle
  double lo = 0.0;
  while (i < pf.count && j >= 0) {
    double end_f = i + 1 < pf.count ? pf.t[i + 1] : 1.0;
    precise double end_b = 1.0 - pb.t[j];
    double hi = end_b < end_f ? end_b : end_f;
    int tf = pf.tri[i], tb = pb.tri[j];
    if (all_front(tf) && all_front(tb)) {
      DepthPlane a = depth_plane(tf), b = depth_plane(tb);
      precise double d0 = plane_at(a, fc) - plane_at(b, fc);
      precise double d1 = plane_at(a, bc) - plane_at(b, bc);
      precise double step = d1 - d0;
      precise double dlo = d0 + lo * step;
      precise double dhi = d0 + hi * step;
      if (dlo <= kDepthTie && dhi >= -kDepthTie && step > kMinDepthStep) {
        precise double denom = d0 - d1;
        double t = div_rn(d0, denom);
        t = t < lo ? lo : (hi < t ? hi : t);  // std::clamp
        // The crossing line is perpendicular to the gradient of d.
        precise double dir_x = a.b - b.b;
        precise double dir_y = -(a.a - b.a);
        if (!pair_owns_direction(horizontal, dir_x, dir_y)) return kNone;
        Pair pr = Pair(t, tf, tb | kCrossingBit);
        if (inside_second) pr.b |= int(0x80000000u);
        return pr;
      }
    }
    lo = hi;
    if (end_f <= end_b) ++i;
    if (end_b <= end_f) --j;
  }
  return kNone;
}

Pair evaluate(int p, int q, bool horizontal) {
  int ip = tri_id[p], iq = tri_id[q];
  if (ip == iq) return kNone;
  bool p_front = iq == 0 || (ip != 0 && (depth(p) < depth(q) || (depth(p) == depth(q) && ip < iq)));
  int f = p_front ? p : q, b = p_front ? q : p;
  int tf = triangle_of(p_front ? ip : iq), tb = triangle_of(p_front ? iq : ip);  // tb < 0: background
  dvec2 fc = centre(f), bc = centre(b);
  // 1. The front surface, towards the other centre.
  WalkPath path_f, path_b;
  WalkEnd wf = walk_surface(tf, tb, fc, bc, path_f);
  if (wf.kind == kSilhouette) return edge_pair(wf, horizontal, !p_front);
  if (wf.kind != kContinues || tb < 0) return kNone;
  // 2. The front surface goes on under the other: follow the other back.
  WalkEnd wb = walk_surface(tb, tf, bc, fc, path_b);
  if (wb.kind == kSilhouette) return edge_pair(wb, horizontal, p_front);
  if (wb.kind != kContinues) return kNone;
  // 3. Both go on under each other.
  return crossing_pair(path_f, path_b, fc, bc, horizontal, !p_front);
}

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int x = p % P.width, y = p / P.width;
  pairs[2 * p] = x + 1 < P.width ? evaluate(p, p + 1, true) : kNone;
  pairs[2 * p + 1] = y + 1 < P.height ? evaluate(p, p + P.width, false) : kNone;
}
