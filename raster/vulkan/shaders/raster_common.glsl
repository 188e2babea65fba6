// Shared by the rasterizer's compute shaders: the CPU kernels' projection,
// triangle classification and watertight edge setup (raster/detail/rasterize_setup.cpp),
// expression for expression in double precision (exact_math.glsl's rules),
// so that every coverage and depth decision, and so every triangle id, is the CPU's.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int width;
  int height;
  int num_vertices;
  int num_tris;
  int cull;    // 0 none, +1 drop back faces, -1 drop front faces
  int pass;    // raster passes: 0 = nearest depth, 1 = smallest id at that depth
  int y_up;    // 1: row 0 is the bottom row (nvdiffrast); 0: the top row
  int flags;   // bit 0 (resolve): also write the coverage kernel's uv and depth;
               // bit 1 (raster passes): depth peeling against binding 9's floor
} P;

#include "vert.glsl"

layout(std430, binding = 0) readonly buffer ClipBuf { float clip[]; };
layout(std430, binding = 1) readonly buffer TriBuf { int tris[]; };
layout(std430, binding = 2) buffer VertBuf { Vert verts[]; };

#include "exact_math.glsl"
#include "clip_of.glsl"

ivec3 tri_of(int t) { return ivec3(tris[3 * t], tris[3 * t + 1], tris[3 * t + 2]); }
bool in_front(int i) { return (verts[i].flags & 1u) != 0u; }
dvec2 screen_of(int i) { return dvec2(verts[i].sx, verts[i].sy); }


// One edge, normalized so that e > 0 is inside; e == 0 is inside when tie.
// mu: the weight of the opposite vertex is e * mu; mz: depth term e * mz.
struct Edge {
  double ax, ay, dx, dy, c, mu, mz;
  bool tie;
};
struct Setup {
  Edge e[3];
  bool z_test;
};

// Top-left rule: inside on e == 0 when the inward gradient (dy, -dx) points to +x, or down.
bool tie_rule(double dx, double dy) { return dy > 0.0 || (dy == 0.0 && dx < 0.0); }

double edge_value(Edge e, double px, double py) {
  precise double row = (py - e.ay) * e.dx;
  precise double v = ((px - e.ax) * e.dy - row) + e.c;
  return v;
}
bool edge_inside(Edge e, double v) { return v > 0.0 || (v == 0.0 && e.tie); }

// Screen edge from pa to pb (canonical order) times sign.
Edge edge_between(dvec2 pa, dvec2 pb, double sign) {
  Edge e;
  e.ax = pa.x;
  e.ay = pa.y;
  precise double dx = sign * (pb.x - pa.x);
  precise double dy = sign * (pb.y - pa.y);
  e.dx = dx;
  e.dy = dy;
  e.c = 0.0;
  e.mu = 0.0;
  e.mz = 0.0;
  e.tie = tie_rule(dx, dy);
  return e;
}

// Canonical vertex order: by screen position, then by index (screen_less).
bool screen_less(int a, int b) {
  dvec2 pa = screen_of(a), pb = screen_of(b);
  if (pa.x != pb.x) return pa.x < pb.x;
  if (pa.y != pb.y) return pa.y < pb.y;
  return a < b;
}
// Same on clip x, y, w (clip_less).
bool clip_less(int a, int b) {
  dvec4 pa = clip_of(a), pb = clip_of(b);
  if (pa.x != pb.x) return pa.x < pb.x;
  if (pa.y != pb.y) return pa.y < pb.y;
  if (pa.w != pb.w) return pa.w < pb.w;
  return a < b;
}

Edge screen_edge(int a, int b, double sign) {
  if (screen_less(b, a)) {
    int s = a;
    a = b;
    b = s;
    sign = -sign;
  }
  return edge_between(screen_of(a), screen_of(b), sign);
}

Edge homogeneous_edge(int a, int b, double sign) {
  if (clip_less(b, a)) {
    int s = a;
    a = b;
    b = s;
    sign = -sign;
  }
  dvec3 n = hcross(homogeneous(a), homogeneous(b));
  Edge e;
  e.ax = 0.0;
  e.ay = 0.0;
  precise double dy = sign * n.x;
  precise double ny = sign * n.y;
  precise double c = sign * n.z;
  e.dy = dy;
  e.dx = -ny;
  e.c = c;
  e.mu = 0.0;
  e.mz = 0.0;
  e.tie = tie_rule(e.dx, e.dy);
  return e;
}

// Twice the signed screen area, 2A = E_12(p0).
double twice_area(ivec3 t) {
  dvec2 p0 = screen_of(t.x), p1 = screen_of(t.y), p2 = screen_of(t.z);
  precise double a2 = (p0.x - p1.x) * (p2.y - p1.y) - (p0.y - p1.y) * (p2.x - p1.x);
  return a2;
}
double homogeneous_det(ivec3 t) {
  return hdot(homogeneous(t.x), hcross(homogeneous(t.y), homogeneous(t.z)));
}

bool needs_clipping(ivec3 t) { return !(in_front(t.x) && in_front(t.y) && in_front(t.z)); }

// Pixel-centre index range [lo, hi] of the interval [a, b], clamped to [0, n-1].
ivec2 pixel_range(double a, double b, int n) {
  a = min(max(a, -2.0), double(n) + 2.0);
  b = min(max(b, -2.0), double(n) + 2.0);
  precise double lo_f = a - 0.5;
  precise double hi_f = b - 0.5;
  int lo_i = int(lo_f), hi_i = int(hi_f);
  if (double(lo_i) < lo_f) lo_i += 1;
  if (double(hi_i) > hi_f) hi_i -= 1;
  return ivec2(max(0, lo_i), min(n - 1, hi_i));
}

// Sutherland-Hodgman clip of a convex polygon against dist(v) >= 0, where
// dist is z + w (plane 0) or w - eps (plane 1). A rounded crossing of the
// first clip can make the signs of the second alternate: up to 3/2 of the
// input's vertices come out (a quadrilateral: 6; rasterize_setup.cpp's
// clip_polygon), so the arrays hold 6.
double plane_dist(dvec4 v, int plane, double eps) {
  precise double d = plane == 0 ? v.z + v.w : v.w - eps;
  return d;
}
int clip_polygon(dvec4 src[6], int n, out dvec4 dst[6], int plane, double eps) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    dvec4 a = src[i];
    dvec4 b = src[i + 1 == n ? 0 : i + 1];
    double da = plane_dist(a, plane, eps), db = plane_dist(b, plane, eps);
    if (da >= 0.0) dst[m++] = a;
    if ((da >= 0.0) != (db >= 0.0)) {
      precise double den = da - db;
      double t = div_rn(da, den);
      precise dvec4 p = a + t * (b - a);
      dst[m++] = p;
    }
  }
  return m;
}

// Classes, as TriClass: 0 raster, 1 clipped, 2 rejected (outside, zero area,
// culled face or no pixel centre in the box).
const int kRaster = 0, kClipped = 1, kRejected = 2;

// classify_triangle: frustum, area, facing, and the pixel box (x0, y0, x1, y1).
int classify_triangle(ivec3 t, out ivec4 box) {
  box = ivec4(0, 0, -1, -1);
  uint oc = (verts[t.x].flags & verts[t.y].flags & verts[t.z].flags) >> 1;
  if (oc != 0u) return kRejected;
  bool clipped = needs_clipping(t);
  bool front;
  if (!clipped) {
    double a2 = twice_area(t);
    if (a2 == 0.0) return kRejected;
    front = a2 > 0.0;
  } else {
    double d = homogeneous_det(t);
    if (d == 0.0 || !finite_bits(d)) return kRejected;
    front = d < 0.0;
  }
  if ((P.cull > 0 && !front) || (P.cull < 0 && front)) return kRejected;

  double minx, maxx, miny, maxy;
  if (!clipped) {
    dvec2 p0 = screen_of(t.x), p1 = screen_of(t.y), p2 = screen_of(t.z);
    minx = min(min(p0.x, p1.x), p2.x);
    maxx = max(max(p0.x, p1.x), p2.x);
    miny = min(min(p0.y, p1.y), p2.y);
    maxy = max(max(p0.y, p1.y), p2.y);
  } else {
    dvec4 poly[6], near_poly[6], pos[6];
    poly[0] = clip_of(t.x);
    poly[1] = clip_of(t.y);
    poly[2] = clip_of(t.z);
    poly[3] = poly[4] = poly[5] = dvec4(0.0);
    int n1 = clip_polygon(poly, 3, near_poly, 0, 0.0);
    double wmax = 0.0;
    for (int k = 0; k < n1; ++k) wmax = max(wmax, abs(near_poly[k].w));
    precise double eps = 1e-12 * wmax;
    int n2 = clip_polygon(near_poly, n1, pos, 1, eps);
    if (n2 == 0) return kRejected;
    // +-inf start values, as bits (no infinity literal in GLSL).
    double inf = packDouble2x32(uvec2(0u, 0x7ff00000u));
    minx = miny = inf;
    maxx = maxy = -inf;
    for (int k = 0; k < n2; ++k) {
      precise double sx = (0.5 * double(P.width)) * (1.0 + div_rn(pos[k].x, pos[k].w));
      precise double sy = (0.5 * double(P.height)) * (1.0 - div_rn(pos[k].y, pos[k].w));
      minx = min(minx, sx);
      maxx = max(maxx, sx);
      miny = min(miny, sy);
      maxy = max(maxy, sy);
    }
    // One pixel of margin for the rounding of the clipped vertices.
    minx -= 1.0;
    miny -= 1.0;
    maxx += 1.0;
    maxy += 1.0;
  }
  ivec2 xr = pixel_range(minx, maxx, P.width);
  ivec2 yr = pixel_range(miny, maxy, P.height);
  box = ivec4(xr.x, yr.x, xr.y, yr.y);
  if (box.x > box.z || box.y > box.w) return kRejected;
  return clipped ? kClipped : kRaster;
}

// setup_edges: e[k] opposite vertex k, with the weights mu, mz.
Setup setup_edges(ivec3 t) {
  Setup s;
  if (!needs_clipping(t)) {
    dvec2 p[3] = dvec2[3](screen_of(t.x), screen_of(t.y), screen_of(t.z));
    int id[3] = int[3](t.x, t.y, t.z);
    precise double a2 = (p[0].x - p[1].x) * (p[2].y - p[1].y) - (p[0].y - p[1].y) * (p[2].x - p[1].x);
    double sign = a2 > 0.0 ? 1.0 : -1.0;
    double inv = div_rn(1.0, abs(a2));
    bool z_test = false;
    for (int k = 0; k < 3; ++k) {
      int ia = k == 2 ? 0 : k + 1, ib = k == 0 ? 2 : k - 1;
      dvec2 pa = p[ia], pb = p[ib];
      bool swp = pb.x < pa.x || (pb.x == pa.x && (pb.y < pa.y || (pb.y == pa.y && id[ib] < id[ia])));
      s.e[k] = edge_between(swp ? pb : pa, swp ? pa : pb, swp ? -sign : sign);
      double z = verts[id[k]].zn;
      s.e[k].mu = inv;
      precise double mz = z * inv;
      s.e[k].mz = mz;
      z_test = z_test || z > 1.0;
    }
    s.z_test = z_test;
    return s;
  }
  // Homogeneous form; edges with both vertices in front keep the screen form.
  double d = homogeneous_det(t);
  double sign = d > 0.0 ? 1.0 : -1.0;
  double inv = div_rn(1.0, abs(d));
  int id[3] = int[3](t.x, t.y, t.z);
  for (int k = 0; k < 3; ++k) {
    int a = id[(k + 1) % 3], b = id[(k + 2) % 3];
    dvec4 ck = clip_of(id[k]);
    double base;
    if (in_front(a) && in_front(b)) {
      s.e[k] = screen_edge(a, b, -sign);
      precise double wab = clip_of(a).w * clip_of(b).w;
      base = wab;
    } else {
      s.e[k] = homogeneous_edge(a, b, sign);
      base = 1.0;
    }
    precise double mu = (base * ck.w) * inv;
    precise double mz = (base * ck.z) * inv;
    s.e[k].mu = mu;
    s.e[k].mz = mz;
  }
  s.z_test = true;
  return s;
}

// Coverage of pixel (x, y) and, when covered and within the depth range, the
// depth z and the weights (u, v) of vertices 1 and 2 (screen barycentrics).
bool shade_pixel(Setup s, int x, int y, out double z, out double u, out double v) {
  double px = double(x) + 0.5, py = double(y) + 0.5;
  double v0 = edge_value(s.e[0], px, py);
  double v1 = edge_value(s.e[1], px, py);
  double v2 = edge_value(s.e[2], px, py);
  z = 0.0;
  u = 0.0;
  v = 0.0;
  if (!(edge_inside(s.e[0], v0) && edge_inside(s.e[1], v1) && edge_inside(s.e[2], v2))) return false;
  precise double zz = (v0 * s.e[0].mz + v1 * s.e[1].mz) + v2 * s.e[2].mz;
  precise double uu = v1 * s.e[1].mu;
  precise double vv = v2 * s.e[2].mu;
  z = zz;
  u = uu;
  v = vv;
  if (s.z_test && !(zz >= -1.0 && zz <= 1.0)) return false;
  return true;
}

// Depth as an unsigned key with the order of the doubles (-0 and +0 equal).
uint64_t depth_key(double z) {
  uvec2 b = unpackDouble2x32(z);
  uint64_t bits = (uint64_t(b.y) << 32) | uint64_t(b.x);
  if (bits == 0x8000000000000000ul) bits = 0ul;
  return (bits & 0x8000000000000000ul) != 0ul ? ~bits : bits | 0x8000000000000000ul;
}
