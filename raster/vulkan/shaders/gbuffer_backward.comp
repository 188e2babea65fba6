#version 460
// Per covered pixel with a non-zero incoming gradient: the adjoint of its
// G-buffer values (raster::barycentric_gbuffer_backward, pixel_adjoint, in
// double), dL/dclip of its three vertices summed per vertex in fixed point
// (fixed_point.glsl, tensor 0): pass 0 finds the largest contribution, pass 1
// adds. The incoming gradient is the sum (in float) of the device's own (the
// interpolate adjoints') and the host's, each present when flagged; each
// holds H*W*4 for rast (u, v, z/w; the id channel ignored), then, when
// flagged, H*W*4 for rast_db.
#include "dispatch.glsl"
#include "gbuffer_common.glsl"
#include "fixed_point.glsl"

const int kDeviceRast = 1, kDeviceDb = 2, kHostRast = 4, kHostDb = 8;

layout(std430, binding = 2) readonly buffer HostGradBuf { float host_grad[]; };
layout(std430, binding = 3) readonly buffer TriIdBuf { int tri_id[]; };
layout(std430, binding = 4) readonly buffer DeviceGradBuf { float device_grad[]; };
// Fixed-point sums: N x 4.
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };

int clip_shift;

void add_clip(int vertex, int d, double x) {
  if (P.pass == 0)
    note_magnitude(0, x);
  else if (x != 0.0)
    atomicAdd(sums[vertex * 4 + d], to_fixed(x, clip_shift));
}

// Incoming gradient i of pixel p: i < 4 rast, 4..7 db.
float incoming(int p, int i) {
  int pixels = P.width * P.height;
  int at = i < 4 ? 4 * p + i : 4 * pixels + 4 * p + (i - 4);
  int device_flag = i < 4 ? kDeviceRast : kDeviceDb, host_flag = i < 4 ? kHostRast : kHostDb;
  float g = 0.0;
  if ((P.flags & device_flag) != 0) g = device_grad[at];
  if ((P.flags & host_flag) != 0) {
    precise float sum = g + host_grad[at];
    g = (P.flags & device_flag) != 0 ? sum : host_grad[at];
  }
  return g;
}

void contribute() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int id = tri_id[p];
  if (id == 0) return;
  bool with_db = (P.flags & (kDeviceDb | kHostDb)) != 0;
  double g[3] = double[3](double(incoming(p, 0)), double(incoming(p, 1)), 0.0);
  double gz = double(incoming(p, 2));
  double h[4] = double[4](0.0, 0.0, 0.0, 0.0);
  bool any = g[0] != 0.0 || g[1] != 0.0 || gz != 0.0;
  if (with_db)
    for (int i = 0; i < 4; ++i) {
      h[i] = double(incoming(p, 4 + i));
      any = any || h[i] != 0.0;
    }
  if (!any) return;
  clip_shift = fixed_point_shift(0, P.count);
  ivec3 tri = tri_of(id - 1);
  int vtx[3] = int[3](tri.x, tri.y, tri.z);
  Terms t = triangle_terms(tri);
  double a[3], S;
  if (!pixel_terms(t, p, a, S)) return;
  double D = t.D;
  double b[2] = double[2](div_rn(a[0], S), div_rn(a[1], S));
  double zw = depth_of(t, a);
  // b_k = a_k / S and z/w = sum a_k z_k / D.
  precise double gb = g[0] * b[0] + g[1] * b[1];
  double bar_a[3], bar_z[3];
  for (int k = 0; k < 3; ++k) {
    precise double ba = div_rn(g[k] - gb, S) + div_rn(gz * t.z[k], D);
    bar_a[k] = ba;
    bar_z[k] = div_rn(gz * a[k], D);
  }
  precise double neg_gz_zw = -gz * zw;
  double bar_D = div_rn(neg_gz_zw, D);
  // db_k/dd = c_k.d / S - a_k C.d / S^2 for d in {x, y}.
  dvec3 bar_c[3] = dvec3[3](dvec3(0.0), dvec3(0.0), dvec3(0.0));
  dvec3 bar_C = dvec3(0.0);
  double bar_S = 0.0;
  if (with_db) {
    precise double S2 = S * S;
    for (int k = 0; k < 2; ++k) {
      double hx = h[2 * k], hy = h[2 * k + 1];
      precise double cx = bar_c[k].x + div_rn(hx, S);
      precise double cy = bar_c[k].y + div_rn(hy, S);
      bar_c[k].x = cx;
      bar_c[k].y = cy;
      precise double Cx = bar_C.x - div_rn(hx * a[k], S2);
      precise double Cy = bar_C.y - div_rn(hy * a[k], S2);
      bar_C.x = Cx;
      bar_C.y = Cy;
      precise double hC = hx * t.C.x + hy * t.C.y;
      precise double hc = hx * t.c[k].x + hy * t.c[k].y;
      precise double na = bar_a[k] - div_rn(hC, S2);
      bar_a[k] = na;
      precise double twice = (2.0 * a[k]) * hC;
      precise double inner = div_rn(twice, S) - hc;
      precise double nS = bar_S + div_rn(inner, S2);
      bar_S = nS;
    }
  }
  dvec3 e = centre_of(p);
  dvec3 bar_V[3];
  for (int k = 0; k < 3; ++k) {
    precise double ba = bar_a[k] + bar_S;  // S = sum a_k
    // a_k = e . c_k, C = sum c_k.
    precise double cx = (bar_c[k].x + ba * e.x) + bar_C.x;
    precise double cy = (bar_c[k].y + ba * e.y) + bar_C.y;
    precise double cw = (bar_c[k].z + ba) + bar_C.z;
    bar_c[k] = dvec3(cx, cy, cw);
    precise dvec3 dV = bar_D * t.c[k];  // dD/dV_k = c_k
    bar_V[k] = dV;
  }
  for (int k = 0; k < 3; ++k) {
    int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    precise dvec3 v1 = bar_V[k1] + hcross(t.V[k2], bar_c[k]);
    bar_V[k1] = v1;
    precise dvec3 v2 = bar_V[k2] + hcross(bar_c[k], t.V[k1]);
    bar_V[k2] = v2;
  }
  // V = (W/2 (x + w), H/2 (w - y), w) -> clip; with y_up dL/dy = +H/2 dL/dV.y.
  double hw = 0.5 * double(P.width), hh = 0.5 * double(P.height), hy = P.y_up != 0 ? hh : -hh;
  for (int k = 0; k < 3; ++k) {
    precise double ox = hw * bar_V[k].x;
    precise double oy = hy * bar_V[k].y;
    precise double ow = (hw * bar_V[k].x + hh * bar_V[k].y) + bar_V[k].z;
    add_clip(vtx[k], 0, ox);
    add_clip(vtx[k], 1, oy);
    add_clip(vtx[k], 2, bar_z[k]);
    add_clip(vtx[k], 3, ow);
  }
}

void main() {
  contribute();
  if (P.pass == 0) publish_magnitudes();
}
