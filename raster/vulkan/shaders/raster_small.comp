#version 460
// One thread per triangle: classify, and scan the box when it is small; a
// larger box is listed (pass 0) for raster_large.comp, in chunks.
#define WORKGROUP_SIZE 64
#include "dispatch.glsl"
#include "raster_common.glsl"
#include "raster_pixels.glsl"

layout(constant_id = 0) const int kMaxSmallBox = 64;

void main() {
  int t = linear_id();
  if (t >= P.num_tris) return;
  ivec3 tri = tri_of(t);
  ivec4 box;
  if (classify_triangle(tri, box) == kRejected) return;
  int n = (box.z - box.x + 1) * (box.w - box.y + 1);
  if (n > kMaxSmallBox) {
    if (P.pass == 0) {
      uint chunks = uint((n + kChunk - 1) / kChunk);
      uint64_t before = atomicAdd(large_counter, (uint64_t(1) << 32) | uint64_t(chunks));
      large[uint(before >> 32)] = uvec2(uint(t), uint(before & 0xffffffffu));
    }
    return;
  }
  Setup s = setup_edges(tri);
  for (int y = box.y; y <= box.w; ++y)
    for (int x = box.x; x <= box.z; ++x) raster_pixel(s, t, x, y);
}
