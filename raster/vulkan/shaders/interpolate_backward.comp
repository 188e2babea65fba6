#version 460
// Per covered pixel: the adjoint of barycentric_interpolate_forward (formulas
// in raster/barycentric_interpolate.h). dL/d(b0, b1) and dL/d(rast_db) are the
// pixel's own and are ADDED (in float, pass 0) to the device's G-buffer
// gradient (H*W*4 for rast, then H*W*4 for rast_db), which rasterize's adjoint
// reads; dL/dattr (N x C) is a sum over pixels taken in fixed point
// (fixed_point.glsl, tensor 0): pass 0 finds the largest contribution, pass 1 adds.
#include "dispatch.glsl"
#include "interpolate_common.glsl"
#include "fixed_point.glsl"

// grad_out (H*W*C), then grad_da (H*W*2K) when K > 0.
layout(std430, binding = 6) readonly buffer GradInBuf { float grad_in[]; };
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 9) buffer GradGBuf { float grad_gbuffer[]; };

int attr_shift;

void add_attr(int vertex, int ch, double x) {
  if (P.pass == 0)
    note_magnitude(0, x);
  else if (x != 0.0)
    atomicAdd(sums[vertex * P.channels + ch], to_fixed(x, attr_shift));
}

void contribute() {
  int p = linear_id();
  int pixels = P.width * P.height;
  if (p >= pixels) return;
  int id = tri_id[p];
  if (id == 0) return;
  int C = P.channels, K = P.num_diff;
  int g0 = p * C, h0 = pixels * C + p * 2 * K;
  ivec3 tri = tri_of(id - 1);
  int vtx[3] = int[3](tri.x, tri.y, tri.z);
  if (P.pass == 0) {
    // dL/db_k = g . (A_k - A_2), dL/d(db_k/dx) = h_x . (A_k - A_2).
    double gb0 = 0.0, gb1 = 0.0;
    for (int ch = 0; ch < C; ++ch) {
      double g = double(grad_in[g0 + ch]), a2 = double(attr[vtx[2] * C + ch]);
      precise double s0 = gb0 + g * (double(attr[vtx[0] * C + ch]) - a2);
      precise double s1 = gb1 + g * (double(attr[vtx[1] * C + ch]) - a2);
      gb0 = s0;
      gb1 = s1;
    }
    precise float r0 = grad_gbuffer[4 * p] + float(gb0);
    precise float r1 = grad_gbuffer[4 * p + 1] + float(gb1);
    grad_gbuffer[4 * p] = r0;
    grad_gbuffer[4 * p + 1] = r1;
    if (K > 0) {
      double d[4] = double[4](0.0, 0.0, 0.0, 0.0);
      for (int j = 0; j < K; ++j) {
        int c = diff[j];
        double a2 = double(attr[vtx[2] * C + c]);
        precise double e0 = double(attr[vtx[0] * C + c]) - a2;
        precise double e1 = double(attr[vtx[1] * C + c]) - a2;
        double hx = double(grad_in[h0 + 2 * j]), hy = double(grad_in[h0 + 2 * j + 1]);
        precise double d0 = d[0] + hx * e0;
        precise double d1 = d[1] + hy * e0;
        precise double d2 = d[2] + hx * e1;
        precise double d3 = d[3] + hy * e1;
        d[0] = d0;
        d[1] = d1;
        d[2] = d2;
        d[3] = d3;
      }
      for (int i = 0; i < 4; ++i) {
        precise float r = grad_gbuffer[4 * pixels + 4 * p + i] + float(d[i]);
        grad_gbuffer[4 * pixels + 4 * p + i] = r;
      }
    }
  }
  attr_shift = fixed_point_shift(0, P.count);
  Weights w = pixel_weights(p);
  // dL/dA_k += w_k g + (dw_k/dx h_x + dw_k/dy h_y) on the differentiated channels.
  for (int k = 0; k < 3; ++k) {
    for (int ch = 0; ch < C; ++ch) {
      precise double ga = w.w[k] * double(grad_in[g0 + ch]);
      add_attr(vtx[k], ch, ga);
    }
    for (int j = 0; j < K; ++j) {
      precise double gd = w.dx[k] * double(grad_in[h0 + 2 * j]) + w.dy[k] * double(grad_in[h0 + 2 * j + 1]);
      add_attr(vtx[k], diff[j], gd);
    }
  }
}

void main() {
  contribute();
  if (P.pass == 0) publish_magnitudes();
}
