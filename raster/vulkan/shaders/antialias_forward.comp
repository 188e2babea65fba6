#version 460
// Per pixel p: out[p] = image[p], then the blends of the pairs that target p,
// in pair order (apply_blend, raster/detail/surface_walk.h):
//   out[target] += w (image[source] - image[target]),  w = |t - 1/2|.
// Each pixel gathers its own value: no two invocations write one pixel.
#include "dispatch.glsl"
#include "antialias_common.glsl"

layout(std430, binding = 7) readonly buffer PairBuf { Pair pairs[]; };
layout(std430, binding = 9) writeonly buffer OutBuf { float out_image[]; };

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int C = P.channels;
  // The pairs that write p (at most four), in pair order.
  Blend blends[4];
  int n = 0;
  ivec4 slots = slots_of(p);
  for (int i = 0; i < 4; ++i) {
    int s = slots[i];
    if (s < 0 || pairs[s].a < 0) continue;
    Blend b = blend_step(s, pairs[s]);
    if (b.target == p) blends[n++] = b;
  }
  for (int ch = 0; ch < C; ++ch) {
    float v = image[p * C + ch];
    for (int i = 0; i < n; ++i) {
      precise double d = double(image[blends[i].source * C + ch]) - double(image[p * C + ch]);
      precise double sum = double(v) + blends[i].w * d;
      v = float(sum);
    }
    out_image[p * C + ch] = v;
  }
}
