#version 460
// Per pixel: the winning triangle's id (1-based, 0 = background) and, with
// flags bit 0, the coverage kernel's own (u, v, depth) (raster/rasterize.h:
// (u, v) the screen weights of vertices 1 and 2, depth z_ndc; background
// (0, 0), 1), for vulkan::rasterize_forward.
#include "dispatch.glsl"
#include "raster_common.glsl"

layout(std430, binding = 4) readonly buffer IdBuf { int ids[]; };
layout(std430, binding = 6) writeonly buffer TriIdOut { int tri_id[]; };
layout(std430, binding = 7) writeonly buffer UvOut { float uv[]; };
layout(std430, binding = 8) writeonly buffer DepthOut { float depth[]; };

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  int t = ids[p];
  bool coverage = (P.flags & 1) != 0;
  if (!coverage) {
    tri_id[p] = t == 0x7fffffff ? 0 : t + 1;
    return;
  }
  if (t == 0x7fffffff) {
    tri_id[p] = 0;
    uv[2 * p] = 0.0;
    uv[2 * p + 1] = 0.0;
    depth[p] = 1.0;
    return;
  }
  Setup s = setup_edges(tri_of(t));
  double z, u, v;
  shade_pixel(s, p % P.width, p / P.width, z, u, v);
  tri_id[p] = t + 1;
  uv[2 * p] = saturate_float(u);
  uv[2 * p + 1] = saturate_float(v);
  depth[p] = saturate_float(z);
}
