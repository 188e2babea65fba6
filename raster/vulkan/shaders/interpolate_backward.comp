#version 460
// Per covered pixel with a non-zero incoming gradient g: the adjoint of
// interpolate_forward (formulas in raster/interpolate.h). dL/du, dL/dv go to
// the pixel's own entries; dL/dattr (N x C) and dL/dclip (N x 4) are sums over
// pixels, taken in fixed point (fixed_point.glsl): pass 0 finds the largest
// contribution per tensor, pass 1 adds them up.
#include "dispatch.glsl"
#include "interpolate_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 5) readonly buffer GradOutBuf { float grad_out[]; };
layout(std430, binding = 6) writeonly buffer GradUvBuf { float grad_uv[]; };
// Fixed-point sums: N x C for attr, then N x 4 for clip.
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };
// Largest magnitudes (fixed_point.glsl): tensor 0 attr, tensor 1 clip.
int attr_shift, clip_shift;

void add_attr(int vertex, int ch, double x) {
  if (P.pass == 0)
    note_magnitude(0, x);
  else if (x != 0.0)
    atomicAdd(sums[vertex * P.channels + ch], to_fixed(x, attr_shift));
}
void add_clip(int vertex, int col, double x) {
  if (P.pass == 0)
    note_magnitude(1, x);
  else if (x != 0.0)
    atomicAdd(sums[P.num_vertices * P.channels + vertex * 4 + col], to_fixed(x, clip_shift));
}

// This invocation's contributions (pass 0: their magnitudes; pass 1: their sums).
void contribute() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int C = P.channels;
  int id = tri_id[p];
  bool any = false;
  for (int ch = 0; ch < C && !any; ++ch) any = grad_out[p * C + ch] != 0.0;
  if (id == 0 || !any) {
    if (P.pass == 0) grad_uv[2 * p] = grad_uv[2 * p + 1] = 0.0;
    return;
  }
  int count = P.width * P.height;
  attr_shift = fixed_point_shift(0, count);
  clip_shift = fixed_point_shift(1, count);
  ivec3 tri = tri_of(id - 1);
  int vtx[3] = int[3](tri.x, tri.y, tri.z);
  Weights pw = pixel_weights(tri, p);
  double g_lambda[3] = double[3](0.0, 0.0, 0.0);
  if (P.perspective == 0) {
    // dL/dlambda_k = g . A_k.
    for (int k = 0; k < 3; ++k) {
      precise double d = 0.0;
      for (int ch = 0; ch < C; ++ch) d += double(grad_out[p * C + ch]) * double(attr[vtx[k] * C + ch]);
      g_lambda[k] = d;
    }
  } else {
    // G_k = dL/dq_k = g . (A_k - A) / s.
    double G[3] = double[3](0.0, 0.0, 0.0);
    for (int ch = 0; ch < C; ++ch) {
      double value = blend(pw, tri, ch);
      double g = double(grad_out[p * C + ch]);
      for (int k = 0; k < 3; ++k) {
        precise double d = G[k] + g * (double(attr[vtx[k] * C + ch]) - value);
        G[k] = d;
      }
    }
    for (int k = 0; k < 3; ++k) {
      precise double gk = G[k] * pw.inv_s;
      G[k] = gk;
    }
    if (pw.from_clip) {
      // q_k = F_k / D: dL/dF_k = G_k / D; dF_k/dV_a = V_b x e, dF_k/dV_b = e x V_a.
      dvec3 gV[3] = dvec3[3](dvec3(0.0), dvec3(0.0), dvec3(0.0));
      for (int k = 0; k < 3; ++k) {
        int a = (k + 1) % 3, b = (k + 2) % 3;
        precise double gF = G[k] * pw.inv_d;
        precise dvec3 ga = gV[a] + gF * hcross(pw.V[b], pw.e);
        precise dvec3 gb = gV[b] + gF * hcross(pw.e, pw.V[a]);
        gV[a] = ga;
        gV[b] = gb;
      }
      double hw = 0.5 * double(P.width), hh = 0.5 * double(P.height);
      for (int k = 0; k < 3; ++k) {
        precise double gx = hw * gV[k].x;
        precise double gy = -hh * gV[k].y;
        precise double gw = (hw * gV[k].x + hh * gV[k].y) + gV[k].z;
        add_clip(vtx[k], 0, gx);
        add_clip(vtx[k], 1, P.y_up != 0 ? -gy : gy);
        add_clip(vtx[k], 3, gw);
      }
    } else {
      // q_k = lambda_k / w_k: dL/dlambda_k = G_k / w_k, dL/dw_k = -G_k q_k / w_k.
      for (int k = 0; k < 3; ++k) {
        precise double gl = G[k] * pw.inv_w[k];
        precise double gw = (-G[k] * pw.q[k]) * pw.inv_w[k];
        g_lambda[k] = gl;
        add_clip(vtx[k], 3, gw);
      }
    }
  }
  // dL/dA_k = weight_k g.
  for (int k = 0; k < 3; ++k)
    for (int ch = 0; ch < C; ++ch) {
      precise double ga = pw.weight[k] * double(grad_out[p * C + ch]);
      add_attr(vtx[k], ch, ga);
    }
  if (P.pass == 0) {
    precise double gu = g_lambda[1] - g_lambda[0];
    precise double gv = g_lambda[2] - g_lambda[0];
    grad_uv[2 * p] = float(gu);
    grad_uv[2 * p + 1] = float(gv);
  }
}

void main() {
  contribute();
  if (P.pass == 0) publish_magnitudes();
}
