#version 460
// Per vertex: the summed dL/dscreen (fixed point, antialias_backward.comp) to
// dL/dclip (screen_to_clip_backward, raster/project.cpp), with g = (W/2 gsx,
// -H/2 gsy): dL/dx = gx / w, dL/dy = gy / w, dL/dw = -(gx x + gy y) / w^2;
// with y_up the y gradient is negated back.
#include "dispatch.glsl"
#include "antialias_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 5) readonly buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 9) writeonly buffer GradClipBuf { float grad_clip[]; };

void main() {
  int i = linear_id();
  if (i >= P.num_vertices) return;
  int shift = fixed_point_shift(0, 2 * P.width * P.height);
  double gsx = from_fixed(sums[2 * i], shift), gsy = from_fixed(sums[2 * i + 1], shift);
  precise double gx = (0.5 * double(P.width)) * gsx;
  precise double gy = -(0.5 * double(P.height)) * gsy;
  vec4 g = vec4(0.0);
  if (gx != 0.0 || gy != 0.0) {
    dvec4 c = clip_of(i);
    double inv_w = div_rn(1.0, c.w);
    precise double ox = gx * inv_w;
    precise double oy = gy * inv_w;
    precise double dot = (gx * c.x + gy * c.y) + 0.0 * c.z;
    precise double ow = -(dot * inv_w * inv_w);
    g = vec4(finite_float(ox), finite_float(oy), 0.0, finite_float(ow));
  }
  if (P.y_up != 0) g.y = -g.y;
  grad_clip[4 * i] = g.x;
  grad_clip[4 * i + 1] = g.y;
  grad_clip[4 * i + 2] = g.z;
  grad_clip[4 * i + 3] = g.w;
}
