#version 460
// The texel gradients' last steps, on the fixed-point sums of every level
// (binding 7), which are turned into doubles in place:
//   mode 0: sum -> sum / 2^S (fixed_point.glsl), stored as the double's bits;
//   mode 1: the box-filter adjoint (mip_backward in raster/mipmap.cpp) from
//           level `level` to level - 1: each parent value += its child's / block size;
//   mode 2: the doubles [0, count) -> float (binding 9).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "fixed_point.glsl"
#include "exact_math.glsl"

layout(push_constant) uniform Params {
  int mode;
  int count;          // values converted (modes 0, 2)
  int channels;
  int level;          // mode 1: the child level
  int contributions;  // mode 0: contributions per value at most (fixed_point_shift)
} P;
layout(local_size_x = 256) in;
layout(std430, binding = 1) readonly buffer LevelBuf { ivec4 level_of[]; };
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 9) writeonly buffer OutBuf { float values[]; };

double double_of_bits(int64_t v) {
  uint64_t u = uint64_t(v);
  return packDouble2x32(uvec2(uint(u & 0xffffffffUL), uint(u >> 32)));
}
int64_t bits_of_double(double d) {
  uvec2 b = unpackDouble2x32(d);
  return int64_t((uint64_t(b.y) << 32) | uint64_t(b.x));
}

// Parents [first, last) of child i along an axis of n parents and m children.
int block_last(int i, int n, int m) { return i == m - 1 ? n : 2 * i + 2; }

void finish(int i) {
  if (P.mode == 0) {
    if (i < P.count) sums[i] = bits_of_double(from_fixed(sums[i], fixed_point_shift(0, P.contributions)));
  } else if (P.mode == 2) {
    if (i < P.count) values[i] = float(double_of_bits(sums[i]));
  } else {
    ivec4 up = level_of[P.level - 1], lv = level_of[P.level];
    int C = P.channels;
    if (i >= up.x * up.y * C) return;
    int c = i % C, texel = i / C;
    int py = texel / up.y, px = texel % up.y;
    int cy = min(py / 2, lv.x - 1), cx = min(px / 2, lv.y - 1);
    int ny = block_last(cy, up.x, lv.x) - 2 * cy, nx = block_last(cx, up.y, lv.y) - 2 * cx;
    double inv = div_rn(1.0, double(nx * ny));
    int parent = (up.z + texel) * C + c;
    int child = (lv.z + cy * lv.y + cx) * C + c;
    precise double sum = double_of_bits(sums[parent]) + double_of_bits(sums[child]) * inv;
    sums[parent] = bits_of_double(sum);
  }
}

// A 1-D dispatch of at most 65535 workgroups, each invocation taking every
// stride-th value (lavapipe ran some invocations of a 2-D dispatch twice).
void main() {
  int n = P.mode == 1 ? level_of[P.level - 1].x * level_of[P.level - 1].y * P.channels : P.count;
  int stride = int(gl_NumWorkGroups.x * gl_WorkGroupSize.x);
  for (int i = int(gl_GlobalInvocationID.x); i < n; i += stride) finish(i);
}
