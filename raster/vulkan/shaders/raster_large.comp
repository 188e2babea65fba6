#version 460
// The chunks of the large boxes listed by raster_small.comp: one invocation
// per chunk of kChunk pixels (box rows in order), over all listed triangles,
// so a huge triangle spreads over many invocations and a modest one takes a
// few. An invocation finds its triangle by a binary search of the entries'
// first chunks, then sets it up itself (the setup is small next to a chunk).
#include "dispatch.glsl"
#include "raster_common.glsl"
#include "raster_pixels.glsl"

void main() {
  uint entries = uint(large_counter >> 32), chunks = uint(large_counter & 0xffffffffu);
  uint stride = gl_NumWorkGroups.x * uint(WORKGROUP_SIZE);
  for (uint g = gl_GlobalInvocationID.x; g < chunks; g += stride) {
    // The last entry whose first chunk is <= g.
    uint lo = 0u, hi = entries - 1u;
    while (lo < hi) {
      uint mid = (lo + hi + 1u) >> 1;
      if (large[mid].y <= g) lo = mid; else hi = mid - 1u;
    }
    int t = int(large[lo].x);
    ivec3 tri = tri_of(t);
    ivec4 box;
    classify_triangle(tri, box);
    Setup s = setup_edges(tri);
    int w = box.z - box.x + 1;
    int n = w * (box.w - box.y + 1);
    int first = int(g - large[lo].y) * kChunk;
    for (int k = first; k < min(n, first + kChunk); ++k) raster_pixel(s, t, box.x + k % w, box.y + k / w);
  }
}
