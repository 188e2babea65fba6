#version 460
// Per vertex: the summed dL/dscreen (fixed point, antialias_backward.comp) to
// dL/dclip (screen_to_clip_backward, raster/project.cpp), with g = (W/2 gsx,
// -H/2 gsy): dL/dx = gx / w, dL/dy = gy / w, dL/dw = -(gx x + gy y) / w^2;
// with y_up the y gradient is negated back. With P.visibility the sums are
// N x 3 and z_ndc's gz adds dL/dz = gz / w and gz z to the dot product.
#include "dispatch.glsl"
#include "antialias_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 5) readonly buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 9) writeonly buffer GradClipBuf { float grad_clip[]; };

void main() {
  int i = linear_id();
  if (i >= P.num_vertices) return;
  int shift = fixed_point_shift(0, contributions_per_element());
  int stride = P.visibility != 0 ? 3 : 2;
  double gsx = from_fixed(sums[stride * i], shift), gsy = from_fixed(sums[stride * i + 1], shift);
  double gz = P.visibility != 0 ? from_fixed(sums[stride * i + 2], shift) : 0.0;
  precise double gx = (0.5 * double(P.width)) * gsx;
  precise double gy = -(0.5 * double(P.height)) * gsy;
  vec4 g = vec4(0.0);
  if (gx != 0.0 || gy != 0.0 || gz != 0.0) {
    dvec4 c = clip_of(i);
    double inv_w = div_rn(1.0, c.w);
    precise double ox = gx * inv_w;
    precise double oy = gy * inv_w;
    precise double oz = gz * inv_w;
    precise double dot = (gx * c.x + gy * c.y) + gz * c.z;
    precise double ow = -(dot * inv_w * inv_w);
    g = vec4(finite_float(ox), finite_float(oy), finite_float(oz), finite_float(ow));
  }
  if (P.y_up != 0) g.y = -g.y;
  grad_clip[4 * i] = g.x;
  grad_clip[4 * i + 1] = g.y;
  grad_clip[4 * i + 2] = g.z;
  grad_clip[4 * i + 3] = g.w;
}
