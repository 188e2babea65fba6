#version 460
// Triangles with large boxes, listed by raster_small.comp: one workgroup per
// listed triangle at a time, its threads over the box's pixels.
#include "raster_common.glsl"
#include "raster_pixels.glsl"

layout(local_size_x = 256) in;

void main() {
  for (uint i = gl_WorkGroupID.x; i < large_count; i += gl_NumWorkGroups.x) {
    int t = int(large[i]);
    ivec3 tri = tri_of(t);
    ivec4 box;
    classify_triangle(tri, box);
    Setup s = setup_edges(tri);
    int w = box.z - box.x + 1;
    int n = w * (box.w - box.y + 1);
    for (int k = int(gl_LocalInvocationID.x); k < n; k += int(gl_WorkGroupSize.x))
      raster_pixel(s, t, box.x + k % w, box.y + k / w);
  }
}
