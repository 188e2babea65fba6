#version 460
// Per element: a fixed-point sum back to float, sum / 2^S (fixed_point.glsl),
// clamped to float's finite range as the CPU kernels write it (finite_float).
// Elements [0, split) use largest[0]'s scale, the rest largest[1]'s.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "dispatch.glsl"
#include "fixed_point.glsl"
#include "exact_math.glsl"

layout(push_constant) uniform Params {
  int count;   // elements
  int split;   // first element of the second tensor
  int pixels;  // contributions per element at most
} P;
layout(std430, binding = 7) readonly buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 9) writeonly buffer OutBuf { float values[]; };

void main() {
  int i = linear_id();
  if (i >= P.count) return;
  values[i] = finite_float(from_fixed(sums[i], fixed_point_shift(i < P.split ? 0 : 1, P.pixels)));
}
