#version 460
// Per pixel: the attributes interpolated over its triangle (interpolate_forward,
// image form); background pixels get zeros.
#include "dispatch.glsl"
#include "interpolate_common.glsl"

layout(std430, binding = 5) writeonly buffer OutBuf { float out_values[]; };

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int C = P.channels;
  int id = tri_id[p];
  if (id == 0) {
    for (int ch = 0; ch < C; ++ch) out_values[p * C + ch] = 0.0;
    return;
  }
  ivec3 tri = tri_of(id - 1);
  Weights pw = pixel_weights(tri, p);
  for (int ch = 0; ch < C; ++ch) out_values[p * C + ch] = float(blend(pw, tri, ch));
}
