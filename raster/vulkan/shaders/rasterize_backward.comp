#version 460
// Per covered pixel with a non-zero incoming gradient (dL/du, dL/dv and, when
// given, dL/ddepth): the adjoint of its (u, v, depth) (raster/rasterize.cpp,
// pixel_grads_screen and pixel_grad_homogeneous), summed per vertex in fixed
// point (fixed_point.glsl): tensor 0 the screen gradients (x, y, z_ndc) of
// triangles in front of the near plane, tensor 1 the clip gradients of the
// homogeneous form. Pass 0 finds the largest contributions, pass 1 adds.
#include "dispatch.glsl"
#include "raster_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 3) readonly buffer TriIdBuf { int tri_id[]; };
layout(std430, binding = 4) readonly buffer GradUvBuf { float grad_uv[]; };
layout(std430, binding = 5) readonly buffer GradDepthBuf { float grad_depth[]; };
// Fixed-point sums: N x 3 screen, then N x 4 clip.
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };

int screen_shift, clip_shift;

void add_screen(int vertex, int d, double x) {
  if (P.pass == 0)
    note_magnitude(0, x);
  else if (x != 0.0)
    atomicAdd(sums[vertex * 3 + d], to_fixed(x, screen_shift));
}
void add_clip(int vertex, int d, double x) {
  if (P.pass == 0)
    note_magnitude(1, x);
  else if (x != 0.0)
    atomicAdd(sums[P.num_vertices * 3 + vertex * 4 + d], to_fixed(x, clip_shift));
}

double edge_function(double qx, double qy, dvec3 a, dvec3 b) {
  precise double e = (qx - a.x) * (b.y - a.y) - (qy - a.y) * (b.x - a.x);
  return e;
}

// pixel_grads_screen: u = E_20/2A, v = E_01/2A, depth = (1-u-v) z0 + u z1 + v z2.
void screen_form(ivec3 tri, double qx, double qy, double gu, double gv, double gd) {
  dvec3 p0 = dvec3(verts[tri.x].sx, verts[tri.x].sy, verts[tri.x].zn);
  dvec3 p1 = dvec3(verts[tri.y].sx, verts[tri.y].sy, verts[tri.y].zn);
  dvec3 p2 = dvec3(verts[tri.z].sx, verts[tri.z].sy, verts[tri.z].zn);
  double inv = safe_inv(edge_function(p0.x, p0.y, p1, p2));
  precise double u = ((qx - p2.x) * (p0.y - p2.y) - (qy - p2.y) * (p0.x - p2.x)) * inv;
  precise double v = ((qx - p0.x) * (p1.y - p0.y) - (qy - p0.y) * (p1.x - p0.x)) * inv;
  precise double gu2 = gu + gd * (p1.z - p0.z);
  precise double gv2 = gv + gd * (p2.z - p0.z);
  precise double g20 = gu2 * inv;
  precise double g01 = gv2 * inv;
  precise double ga2 = -(gu2 * u + gv2 * v) * inv;
  precise double g2x = 0.0 + g20 * (qy - p0.y);
  precise double g2y = 0.0 + g20 * (p0.x - qx);
  precise double g0x = 0.0 + g20 * (p2.y - qy);
  precise double g0y = 0.0 + g20 * (qx - p2.x);
  g0x += g01 * (qy - p1.y);
  g0y += g01 * (p1.x - qx);
  precise double g1x = 0.0 + g01 * (p0.y - qy);
  precise double g1y = 0.0 + g01 * (qx - p0.x);
  g1x += ga2 * (p0.y - p2.y);
  g1y += ga2 * (p2.x - p0.x);
  g2x += ga2 * (p1.y - p0.y);
  g2y += ga2 * (p0.x - p1.x);
  g0x += ga2 * (p2.y - p1.y);
  g0y += ga2 * (p1.x - p2.x);
  precise double gz0 = 0.0 + gd * ((1.0 - u) - v);
  precise double gz1 = 0.0 + gd * u;
  precise double gz2 = 0.0 + gd * v;
  add_screen(tri.x, 0, g0x);
  add_screen(tri.x, 1, g0y);
  add_screen(tri.x, 2, gz0);
  add_screen(tri.y, 0, g1x);
  add_screen(tri.y, 1, g1y);
  add_screen(tri.y, 2, gz1);
  add_screen(tri.z, 0, g2x);
  add_screen(tri.z, 1, g2y);
  add_screen(tri.z, 2, gz2);
}

// pixel_grad_homogeneous: u = w1 F1/D, v = w2 F2/D, depth = sum z_k F_k/D.
void homogeneous_form(ivec3 tri, double px, double py, double gu, double gv, double gd) {
  int id[3] = int[3](tri.x, tri.y, tri.z);
  dvec3 V[3] = dvec3[3](homogeneous(tri.x), homogeneous(tri.y), homogeneous(tri.z));
  dvec3 s = dvec3(px, py, 1.0);
  double w[3], z[3], F[3];
  for (int k = 0; k < 3; ++k) {
    w[k] = V[k].z;
    z[k] = clip_of(id[k]).z;
    F[k] = hdot(s, hcross(V[(k + 1) % 3], V[(k + 2) % 3]));
  }
  double inv = safe_inv(hdot(V[0], hcross(V[1], V[2])));
  precise double u = (w[1] * F[1]) * inv;
  precise double v = (w[2] * F[2]) * inv;
  precise double depth = ((z[0] * F[0] + z[1] * F[1]) + z[2] * F[2]) * inv;
  double gF[3];
  for (int k = 0; k < 3; ++k) {
    precise double g = (gd * z[k]) * inv;
    gF[k] = g;
  }
  precise double gF1 = gF[1] + (gu * w[1]) * inv;
  precise double gF2 = gF[2] + (gv * w[2]) * inv;
  gF[1] = gF1;
  gF[2] = gF2;
  precise double gD = -((gu * u + gv * v) + gd * depth) * inv;
  dvec3 gV[3] = dvec3[3](dvec3(0.0), dvec3(0.0), dvec3(0.0));
  for (int k = 0; k < 3; ++k) {
    int a = (k + 1) % 3, b = (k + 2) % 3;
    precise dvec3 ga = gV[a] + gF[k] * hcross(V[b], s);
    gV[a] = ga;
    precise dvec3 gb = gV[b] + gF[k] * hcross(s, V[a]);
    gV[b] = gb;
    precise dvec3 gk = gV[k] + gD * hcross(V[a], V[b]);
    gV[k] = gk;
  }
  precise double w1 = gV[1].z + (gu * F[1]) * inv;
  precise double w2 = gV[2].z + (gv * F[2]) * inv;
  gV[1].z = w1;
  gV[2].z = w2;
  double hw = 0.5 * double(P.width), hh = 0.5 * double(P.height);
  for (int k = 0; k < 3; ++k) {
    precise double ox = hw * gV[k].x;
    precise double oy = -(hh * gV[k].y);
    precise double oz = (gd * F[k]) * inv;
    precise double ow = (hw * gV[k].x + hh * gV[k].y) + gV[k].z;
    add_clip(id[k], 0, ox);
    add_clip(id[k], 1, oy);
    add_clip(id[k], 2, oz);
    add_clip(id[k], 3, ow);
  }
}

// This invocation's contributions (pass 0: their magnitudes; pass 1: their sums).
void contribute() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int id = tri_id[p];
  if (id == 0) return;
  double gu = double(grad_uv[2 * p]), gv = double(grad_uv[2 * p + 1]);
  double gd = (P.flags & 1) != 0 ? double(grad_depth[p]) : 0.0;
  if (gu == 0.0 && gv == 0.0 && gd == 0.0) return;
  int count = P.width * P.height;
  screen_shift = fixed_point_shift(0, count);
  clip_shift = fixed_point_shift(1, count);
  ivec3 tri = tri_of(id - 1);
  double px = double(p % P.width) + 0.5, py = double(p / P.width) + 0.5;
  if (needs_clipping(tri))
    homogeneous_form(tri, px, py, gu, gv, gd);
  else
    screen_form(tri, px, py, gu, gv, gd);
}

void main() {
  contribute();
  if (P.pass == 0) publish_magnitudes();
}
