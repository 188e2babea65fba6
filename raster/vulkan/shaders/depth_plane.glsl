// visibility_antialias's DepthPlane (raster/visibility_antialias.cpp),
// expression for expression: a triangle's z_ndc over the screen, z(c) = z0 +
// a (cx - x0) + b (cy - y0), and its screen barycentrics. Needs
// antialias_common.glsl and the `tris` buffer.

struct DepthPlane {
  double x0, y0, z0, a, b;
  double ex1, ey1, ex2, ey2, inv_d;  // edge vectors from vertex 0, 1 / (2 area)
};

DepthPlane depth_plane(int t) {
  int i0 = tris[3 * t], i1 = tris[3 * t + 1], i2 = tris[3 * t + 2];
  DepthPlane p;
  p.x0 = verts[i0].sx;
  p.y0 = verts[i0].sy;
  p.z0 = verts[i0].zn;
  precise double ex1 = verts[i1].sx - p.x0, ey1 = verts[i1].sy - p.y0;
  precise double ex2 = verts[i2].sx - p.x0, ey2 = verts[i2].sy - p.y0;
  p.ex1 = ex1;
  p.ey1 = ey1;
  p.ex2 = ex2;
  p.ey2 = ey2;
  precise double det = ex1 * ey2 - ex2 * ey1;
  p.inv_d = safe_inv(det);  // degenerate: large, finite
  precise double dz1 = verts[i1].zn - p.z0, dz2 = verts[i2].zn - p.z0;
  precise double a = (dz1 * ey2 - dz2 * ey1) * p.inv_d;
  precise double b = (ex1 * dz2 - ex2 * dz1) * p.inv_d;
  p.a = a;
  p.b = b;
  return p;
}

double plane_at(DepthPlane p, dvec2 c) {
  precise double z = p.z0 + p.a * (c.x - p.x0) + p.b * (c.y - p.y0);
  return z;
}

// lambda_k(c), k = 0, 1, 2.
dvec3 plane_barycentrics(DepthPlane p, dvec2 c) {
  precise double dx = c.x - p.x0, dy = c.y - p.y0;
  precise double l1 = (dx * p.ey2 - dy * p.ex2) * p.inv_d;
  precise double l2 = (p.ex1 * dy - p.ey1 * dx) * p.inv_d;
  precise double l0 = 1.0 - l1 - l2;
  return dvec3(l0, l1, l2);
}
