// Shared by the antialias shaders: the CPU kernel's silhouette pairs
// (raster/antialias.cpp, raster/detail/surface_walk.cpp), expression for expression
// in double (the rules of exact_math.glsl: `precise`, div_rn, finiteness
// on the bits). Pixel pairs are stored per pixel p, two slots: 2p for
// (p, p + 1) and 2p + 1 for (p, p + W); the CPU's pair order (row-major by the
// top/left pixel, horizontal before vertical) is the slots' order.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int width;
  int height;
  int num_vertices;
  int id_offset;  // the row of `tris` where the G-buffer's triangles start (a range's first; else 0)
  int channels;
  int pass;  // antialias_backward: 0 = image gradient and largest magnitudes, 1 = sums
  int y_up;  // the G-buffer was rasterized with y negated (row 0 at the bottom)
  int visibility;  // the pairs are visibility_antialias's (visibility_pairs.comp)
} P;

#include "vert.glsl"

// A blended pair: the silhouette edge a-b crossed at t along the segment from
// the inside centre to the outside centre. a < 0: no blend. b's bit 31 is set
// when the inside pixel is the second of the pair (right or lower); bit 30
// when the boundary is an intersection (visibility_pairs.comp): a and b are
// then the triangles of the inside's and the outside's surface there.
struct Pair {
  double t;
  int a;
  int b;
};

layout(std430, binding = 0) readonly buffer ClipBuf { float clip[]; };
layout(std430, binding = 2) readonly buffer VertBuf { Vert verts[]; };
layout(std430, binding = 6) readonly buffer ImageBuf { float image[]; };

#include "exact_math.glsl"
#include "clip_of.glsl"

bool in_front(int i) { return (verts[i].flags & 1u) != 0u; }
dvec2 screen_of(int i) { return dvec2(verts[i].sx, verts[i].sy); }

// Screen edge function E(q; a, b) = (qx - ax)(by - ay) - (qy - ay)(bx - ax).
double edge_fn(dvec2 q, dvec2 a, dvec2 b) {
  precise double e = (q.x - a.x) * (b.y - a.y) - (q.y - a.y) * (b.x - a.x);
  return e;
}

// The triangle (row of `tris`) of a G-buffer id (numbered from 1 in its
// triangles), -1 for the background (0).
int triangle_of(int id) { return id == 0 ? -1 : id - 1 + P.id_offset; }

// The centre of pixel p.
dvec2 centre(int p) { return dvec2(double(p % P.width) + 0.5, double(p / P.width) + 0.5); }

// Slot s's pair: its two pixels (top/left first) and whether it blends.
ivec2 pair_pixels(int s) {
  int p = s >> 1;
  return ivec2(p, (s & 1) == 0 ? p + 1 : p + P.width);
}
int pair_b(Pair pr) { return pr.b & 0x3fffffff; }
const int kCrossingBit = 0x40000000;
bool pair_is_crossing(Pair pr) { return (pr.b & kCrossingBit) != 0; }
// (inside, outside) of a blending slot s.
ivec2 inside_outside(int s, Pair pr) {
  ivec2 pq = pair_pixels(s);
  return (pr.b & int(0x80000000u)) != 0 ? pq.yx : pq;
}

// blend_step (raster/detail/surface_walk.h): the pixel beyond t = 1/2 (target)
// takes w = |t - 1/2| of the other's colour (source).
struct Blend {
  int target;
  int source;
  double w;
};
Blend blend_step(int s, Pair pr) {
  ivec2 io = inside_outside(s, pr);
  Blend b;
  bool outward = pr.t > 0.5;
  b.target = outward ? io.y : io.x;
  b.source = outward ? io.x : io.y;
  precise double w = outward ? pr.t - 0.5 : 0.5 - pr.t;
  b.w = w;
  return b;
}

// The slots of the (up to four) pairs pixel p belongs to, in pair order
// (-1 where the neighbour is outside the image): (p - W, p), (p - 1, p),
// (p, p + 1), (p, p + W).
ivec4 slots_of(int p) {
  int x = p % P.width, y = p / P.width;
  return ivec4(y > 0 ? 2 * (p - P.width) + 1 : -1, x > 0 ? 2 * (p - 1) : -1, x + 1 < P.width ? 2 * p : -1,
               y + 1 < P.height ? 2 * p + 1 : -1);
}

// The adjoint's fixed-point sums (antialias_backward.comp, antialias_finish.comp):
// each vertex coordinate gets at most one contribution per slot, two from a
// crossing whose triangles share the vertex.
int contributions_per_element() { return (P.visibility != 0 ? 4 : 2) * P.width * P.height; }
