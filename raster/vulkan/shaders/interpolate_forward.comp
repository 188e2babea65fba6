#version 460
// Per pixel: the attributes interpolated over its triangle and, for the
// channels in diff, their screen derivatives (dA/dx, dA/dy)
// (raster::barycentric_interpolate_forward); background pixels get zeros.
#include "dispatch.glsl"
#include "interpolate_common.glsl"

layout(std430, binding = 6) writeonly buffer OutBuf { float out_values[]; };
layout(std430, binding = 7) writeonly buffer OutDaBuf { float out_da[]; };

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int C = P.channels, K = P.num_diff;
  int id = tri_id[p];
  if (id == 0) {
    for (int ch = 0; ch < C; ++ch) out_values[p * C + ch] = 0.0;
    for (int j = 0; j < 2 * K; ++j) out_da[p * 2 * K + j] = 0.0;
    return;
  }
  ivec3 tri = tri_of(id - 1);
  Weights k = pixel_weights(p);
  for (int ch = 0; ch < C; ++ch) out_values[p * C + ch] = float(blend(k.w, tri, ch));
  for (int j = 0; j < K; ++j) {
    out_da[p * 2 * K + 2 * j] = float(blend(k.dx, tri, diff[j]));
    out_da[p * 2 * K + 2 * j + 1] = float(blend(k.dy, tri, diff[j]));
  }
}
