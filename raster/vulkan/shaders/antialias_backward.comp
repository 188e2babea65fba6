#version 460
// The adjoint of antialias_forward (raster/antialias.cpp, antialias_backward).
// Pass 0, per pixel p: dL/dimage[p] = g[p], then in pair order -w g[p] where
// p is a pair's target and +w g[target] where it is its source
// (blend_image_adjoint, raster/detail/surface_walk.h); and the largest screen
// contribution. Pass 1, per pixel: its two slots' contributions to the edge
// vertices' screen positions, summed in fixed point (fixed_point.glsl):
//   dL/dt = g[target] . (image[inside] - image[outside])
//   t = E_i / (E_i - E_o): dt/dE_i = -E_o / D^2, dt/dE_o = E_i / D^2
//   dE/dax = qy - by, dE/day = bx - qx, dE/dbx = ay - qy, dE/dby = qx - ax.
#include "dispatch.glsl"
#include "antialias_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 3) readonly buffer GradOutBuf { float grad_out[]; };
layout(std430, binding = 4) writeonly buffer GradImageBuf { float grad_image[]; };
// Fixed-point sums of dL/dscreen: N x 2.
layout(std430, binding = 5) buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 7) readonly buffer PairBuf { Pair pairs[]; };

void image_gradient(int p) {
  int C = P.channels;
  // The pairs p takes part in (at most four), in pair order.
  Blend blends[4];
  int n = 0;
  ivec4 slots = slots_of(p);
  for (int i = 0; i < 4; ++i) {
    int s = slots[i];
    if (s < 0 || pairs[s].a < 0) continue;
    Blend b = blend_step(s, pairs[s]);
    if (b.target == p || b.source == p) blends[n++] = b;
  }
  for (int ch = 0; ch < C; ++ch) {
    precise float gi = grad_out[p * C + ch];
    for (int i = 0; i < n; ++i) {
      double g = double(grad_out[blends[i].target * C + ch]);
      if (g == 0.0) continue;
      precise double wg = blends[i].w * g;
      gi = blends[i].target == p ? gi - float(wg) : gi + float(wg);
    }
    grad_image[p * C + ch] = gi;
  }
}

void add_screen(int vertex, int axis, double x, int shift) {
  if (P.pass == 0)
    note_magnitude(0, x);
  else if (x != 0.0)
    atomicAdd(sums[2 * vertex + axis], to_fixed(x, shift));
}

// Slot s's contributions to its edge's two vertices.
void clip_gradient(int s, int shift) {
  Pair pr = pairs[s];
  if (pr.a < 0) return;
  int C = P.channels;
  ivec2 io = inside_outside(s, pr);
  int target = blend_step(s, pr).target;
  precise double gt = 0.0;
  for (int ch = 0; ch < C; ++ch)
    gt += double(grad_out[target * C + ch]) * (double(image[io.x * C + ch]) - double(image[io.y * C + ch]));
  if (gt == 0.0) return;
  int a = pr.a, b = pair_b(pr);
  dvec2 sa = screen_of(a), sb = screen_of(b), ci = centre(io.x), co = centre(io.y);
  double ei = edge_fn(ci, sa, sb), eo = edge_fn(co, sa, sb);
  precise double d = ei - eo;
  double inv_d = safe_inv(d);
  precise double g_ei = -eo * inv_d * inv_d * gt;
  precise double g_eo = ei * inv_d * inv_d * gt;
  precise double gax = g_ei * (ci.y - sb.y) + g_eo * (co.y - sb.y);
  precise double gay = g_ei * (sb.x - ci.x) + g_eo * (sb.x - co.x);
  precise double gbx = g_ei * (sa.y - ci.y) + g_eo * (sa.y - co.y);
  precise double gby = g_ei * (ci.x - sa.x) + g_eo * (co.x - sa.x);
  add_screen(a, 0, gax, shift);
  add_screen(a, 1, gay, shift);
  add_screen(b, 0, gbx, shift);
  add_screen(b, 1, gby, shift);
}

// This invocation's contributions (pass 0: their magnitudes; pass 1: their sums).
void contribute() {
  int p = linear_id();
  int pixels = P.width * P.height;
  if (p >= pixels) return;
  if (P.pass == 0) image_gradient(p);
  // Each vertex coordinate gets at most one contribution per slot.
  int shift = P.pass == 0 ? 0 : fixed_point_shift(0, 2 * pixels);
  clip_gradient(2 * p, shift);
  clip_gradient(2 * p + 1, shift);
}

void main() {
  contribute();
  if (P.pass == 0) publish_magnitudes();
}
