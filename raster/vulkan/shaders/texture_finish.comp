#version 460
// The texel gradients' last steps, from the fixed-point sums of every level
// (binding 7) to float (binding 9), for each of `faces` textures whose levels
// lie face_texels apart (a cube map's 6 faces; 1 for a 2D texture):
//   mode 0: values [first, count) of each face to double (sum / 2^S,
//           fixed_point.glsl), stored in place as the double's bits (the
//           coarsest level);
//   mode 1: the box-filter adjoint (mip_backward in raster/mipmap.cpp) from
//           level `level` to level - 1, per child texel: each of its parents'
//           values = its own sum / 2^S + the child's / block size (every parent
//           has one child, so each is converted once, here), stored as double
//           bits, or for level 0 rounded to float into binding 9 (the faces'
//           level 0 one after the other);
//   mode 2: values [0, count) straight to float (no box filter).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "dispatch.glsl"
#include "fixed_point.glsl"

layout(push_constant) uniform Params {
  int mode;
  int count;          // modes 0, 2: values converted up to
  int channels;
  int level;          // mode 1: the child level
  int contributions;  // contributions per value at most (fixed_point_shift)
  int first;          // mode 0: the first value converted
  int faces;          // modes 0, 1: faces (1 or 6)
  int face_texels;    // modes 0, 1: texels of one face's levels
} P;
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

// 1 / (block size) for blocks of 1 x 1 to 3 x 3 parents, correctly rounded.
double inverse_count(int n) {
  return n == 1 ? 1.0 : n == 2 ? 0.5 : n == 3 ? 0.3333333333333333LF : n == 4 ? 0.25
       : n == 6 ? 0.16666666666666666LF : 0.1111111111111111LF;
}

// Mode 1 for child texel `texel` of level P.level of `face` (scale: 2^-S).
void to_parents(int face, int texel, double scale) {
  ivec4 up = level_of[P.level - 1], lv = level_of[P.level];
  int C = P.channels, base = face * P.face_texels, out_base = face * level_of[0].x * level_of[0].y;
  int cy = texel / lv.y, cx = texel - cy * lv.y;
  int py1 = block_last(cy, up.x, lv.x), px1 = block_last(cx, up.y, lv.y);
  double inv = inverse_count((py1 - 2 * cy) * (px1 - 2 * cx));
  for (int c = 0; c < C; ++c) {
    double g = double_of_bits(sums[(base + lv.z + texel) * C + c]);
    for (int py = 2 * cy; py < py1; ++py)
      for (int px = 2 * cx; px < px1; ++px) {
        int parent = (base + up.z + py * up.y + px) * C + c;
        precise double sum = double(sums[parent]) * scale + g * inv;
        if (P.level == 1)
          values[(out_base + py * up.y + px) * C + c] = float(sum);
        else
          sums[parent] = bits_of_double(sum);
      }
  }
}

// One invocation per item: a value (modes 0, 2) or a child texel (mode 1).
void main() {
  int k = linear_id();
  int per_face = P.mode == 0 ? P.count - P.first : level_of[P.level].x * level_of[P.level].y;
  int items = P.mode == 2 ? P.count : per_face * P.faces;
  if (k >= items) return;
  int face = P.mode == 2 ? 0 : k / per_face;
  // from_fixed's ldexp as one multiplication by 2^-S (a normal double: |S| <= 1000), exact.
  double scale = ldexp(1.0, -fixed_point_shift(0, P.contributions));
  if (P.mode == 0) {
    int i = face * P.face_texels * P.channels + P.first + k - face * per_face;
    sums[i] = bits_of_double(double(sums[i]) * scale);
  } else if (P.mode == 2) {
    values[k] = float(double(sums[k]) * scale);
  } else {
    to_parents(face, k - face * per_face, scale);
  }
}
