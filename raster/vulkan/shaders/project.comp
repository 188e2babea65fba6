#version 460
// Per vertex: screen position, z_ndc, in-front flag and frustum outcode
// (project_vertices_into in raster/detail/rasterize_setup.cpp).
#include "dispatch.glsl"
#include "raster_common.glsl"

void main() {
  int i = linear_id();
  if (i >= P.num_vertices) return;
  dvec4 c = clip_of(i);
  bool front = c.w > 0.0 && c.z >= -c.w;
  precise double sx = (0.5 * double(P.width)) * (1.0 + div_rn(c.x, c.w));
  precise double sy = (0.5 * double(P.height)) * (1.0 - div_rn(c.y, c.w));
  double zn = div_rn(c.z, c.w);
  bool ok = front && finite_bits(sx) && finite_bits(sy) && finite_bits(zn);
  uint outcode = uint(c.w <= 0.0) | uint(c.x > c.w) << 1 | uint(c.x < -c.w) << 2 | uint(c.y > c.w) << 3 |
                 uint(c.y < -c.w) << 4 | uint(c.z < -c.w) << 5 | uint(c.z > c.w) << 6;
  verts[i].sx = ok ? sx : 0.0;
  verts[i].sy = ok ? sy : 0.0;
  verts[i].zn = ok ? zn : 0.0;
  verts[i].flags = uint(ok) | outcode << 1;
  verts[i].pad = 0u;
}
