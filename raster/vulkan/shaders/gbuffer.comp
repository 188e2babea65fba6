#version 460
// Per pixel: nvdiffrast's G-buffer from the coverage (tri_id, 1-based):
// rast = (b0, b1, z/w, id) and, with flags bit 0, rast_db = (db0/dx, db0/dy,
// db1/dx, db1/dy) (raster::barycentric_gbuffer_forward with id_offset 0);
// background pixels all zero.
#include "dispatch.glsl"
#include "gbuffer_common.glsl"

layout(std430, binding = 6) readonly buffer TriIdBuf { int tri_id[]; };
layout(std430, binding = 7) writeonly buffer RastOut { float rast[]; };
layout(std430, binding = 8) writeonly buffer DbOut { float db[]; };

double clamp_to(double x, double lo, double hi) { return x < lo ? lo : hi < x ? hi : x; }

void main() {
  int p = linear_id();
  if (p >= P.width * P.height) return;
  bool with_db = (P.flags & 1) != 0;
  int id = tri_id[p];
  float r[4] = float[4](0.0, 0.0, 0.0, float(id));
  float d[4] = float[4](0.0, 0.0, 0.0, 0.0);
  if (id != 0) {
    Terms t = triangle_terms(tri_of(id - 1));
    double a[3], S;
    if (pixel_terms(t, p, a, S)) {
      double b0 = clamp_to(div_rn(a[0], S), 0.0, 1.0), b1 = clamp_to(div_rn(a[1], S), 0.0, 1.0);
      precise double sum = b0 + b1;
      if (sum > 1.0) {
        b0 = div_rn(b0, sum);
        b1 = div_rn(b1, sum);
      }
      r[0] = float(b0);
      r[1] = float(b1);
      r[2] = float(clamp_to(depth_of(t, a), -1.0, 1.0));
      if (with_db) {
        precise double S2 = S * S;
        for (int k = 0; k < 2; ++k) {
          precise double nx = t.c[k].x * S - a[k] * t.C.x;
          precise double ny = t.c[k].y * S - a[k] * t.C.y;
          d[2 * k] = finite_float(div_rn(nx, S2));
          d[2 * k + 1] = finite_float(div_rn(ny, S2));
        }
      }
    }
  }
  for (int i = 0; i < 4; ++i) rast[4 * p + i] = r[i];
  if (with_db)
    for (int i = 0; i < 4; ++i) db[4 * p + i] = d[i];
}
