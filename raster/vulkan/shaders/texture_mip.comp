#version 460
// Level `level` of a 2D texture's mip chain from level - 1, in place in the
// texels (binding 0; the levels' (height, width, offset, 0) at binding 1):
// raster::mip_build's box filter (raster/mipmap.cpp), one invocation per
// texel of the level; for a cube map each of the 6 faces' chains
// (raster::cube_mip_build), face f's levels `face_values` floats after face
// f - 1's. Each value is the mean of its parent block (2 x 2; 3
// wide or high at an odd edge), summed in double in the CPU's order (rows,
// then columns), times the same double 1 / block size (a constant folded at
// compile time, so exactly the CPU's), rounded to float: the CPU's bits.
#include "dispatch.glsl"

layout(push_constant) uniform Params {
  int level;     // the level made (>= 1)
  int channels;
  int count;        // texels of the level (of one face)
  int faces;        // 1, or 6 for a cube map
  int face_values;  // floats from one face's level 0 to the next's
  int unused0, unused1, unused2;
} P;
layout(std430, binding = 0) buffer TexelBuf { float texels[]; };
layout(std430, binding = 1) readonly buffer LevelBuf { ivec4 level_of[]; };

// 1 / n for the block sizes n = rows x columns, rows and columns 1 to 3.
const double kInverse[10] = double[10](0.0LF, 1.0LF, 1.0LF / 2.0LF, 1.0LF / 3.0LF, 1.0LF / 4.0LF, 0.0LF,
                                       1.0LF / 6.0LF, 0.0LF, 0.0LF, 1.0LF / 9.0LF);

void main() {
  int k = linear_id();
  if (k >= P.count * P.faces) return;
  int face = k / P.count, i = k - face * P.count;
  int first = face * P.face_values;
  ivec4 up = level_of[P.level - 1], lv = level_of[P.level];  // (height, width, offset, 0)
  int y = i / lv.y, x = i - y * lv.y;
  // block_first / block_last: the last row (column) takes the odd parent too.
  int py0 = 2 * y, py1 = y == lv.x - 1 ? up.x : 2 * y + 2;
  int px0 = 2 * x, px1 = x == lv.y - 1 ? up.y : 2 * x + 2;
  double inv = kInverse[(py1 - py0) * (px1 - px0)];
  int C = P.channels;
  for (int c = 0; c < C; ++c) {
    double acc = 0.0LF;
    for (int py = py0; py < py1; ++py)
      for (int px = px0; px < px1; ++px) acc += double(texels[first + (up.z + py * up.y + px) * C + c]);
    texels[first + (lv.z + i) * C + c] = float(acc * inv);
  }
}
