#version 460
// Per vertex: rasterize_backward's fixed-point sums to dL/dclip (N x 4): the
// screen part through the viewport and w-divide adjoints
// (screen_to_clip_backward: g_ndc = (W/2 g_xs, -H/2 g_ys, g_z),
// dL/d(x, y, z) = g_ndc / w, dL/dw = -(g_ndc . (x, y, z)) / w^2), plus the
// clip part; y negated back with y_up; clamped to float's finite range.
#include "dispatch.glsl"
#include "raster_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 7) readonly buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 9) writeonly buffer OutBuf { float grad_clip[]; };

void main() {
  int i = linear_id();
  if (i >= P.num_vertices) return;
  int count = P.width * P.height;
  int screen_shift = fixed_point_shift(0, count), clip_shift = fixed_point_shift(1, count);
  int N = P.num_vertices;
  double out_g[4];
  for (int d = 0; d < 4; ++d) out_g[d] = from_fixed(sums[3 * N + 4 * i + d], clip_shift);
  double gs0 = from_fixed(sums[3 * i], screen_shift), gs1 = from_fixed(sums[3 * i + 1], screen_shift);
  double gs2 = from_fixed(sums[3 * i + 2], screen_shift);
  precise double g0 = (0.5 * double(P.width)) * gs0;
  precise double g1 = -(0.5 * double(P.height)) * gs1;
  double g2 = gs2;
  if (g0 != 0.0 || g1 != 0.0 || g2 != 0.0) {
    dvec4 c = clip_of(i);
    double inv_w = div_rn(1.0, c.w);
    precise double dot = (g0 * c.x + g1 * c.y) + g2 * c.z;
    precise double o0 = out_g[0] + g0 * inv_w;
    precise double o1 = out_g[1] + g1 * inv_w;
    precise double o2 = out_g[2] + g2 * inv_w;
    precise double o3 = out_g[3] - (dot * inv_w) * inv_w;
    out_g[0] = o0;
    out_g[1] = o1;
    out_g[2] = o2;
    out_g[3] = o3;
  }
  if (P.y_up != 0) out_g[1] = -out_g[1];
  for (int d = 0; d < 4; ++d) grad_clip[4 * i + d] = finite_float(out_g[d]);
}
