// An independent evaluation of the G-buffer's values for the op tests: the
// barycentrics of the point of a triangle seen through a pixel, from the 3 x 3
// linear system of the pixel's ray (no homogeneous cross products, no screen
// barycentrics).
#pragma once

#include <cstdint>
#include <vector>

namespace gr::testing {

// (b0, b1, b2) of the point of triangle t seen at NDC (x, y), and its z/w:
// the clip point P = sum b_k V_k projects to (x, y) and sum b_k = 1, i.e.
// sum b_k (x_k - x w_k) = 0, sum b_k (y_k - y w_k) = 0 (Cramer's rule).
// Valid for triangles crossing w = 0 too. clip: N x 4, tris: M x 3.
struct PixelRay {
  double b[3], zw;
};
inline PixelRay pixel_ray(const std::vector<double>& clip, const std::vector<std::int32_t>& tris, int t, double x,
                          double y) {
  double r0[3], r1[3];
  const double* v[3];
  for (int k = 0; k < 3; ++k) {
    v[k] = &clip[4 * static_cast<std::size_t>(tris[3 * t + k])];
    r0[k] = v[k][0] - x * v[k][3];
    r1[k] = v[k][1] - y * v[k][3];
  }
  // Rows r0, r1, (1, 1, 1); right-hand side (0, 0, 1): b_k = the row-3 cofactor of column k / det.
  double cof[3];
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    cof[k] = r0[i] * r1[j] - r0[j] * r1[i];
  }
  const double det = cof[0] + cof[1] + cof[2];
  PixelRay ray;
  double z = 0, w = 0;
  for (int k = 0; k < 3; ++k) {
    ray.b[k] = cof[k] / det;
    z += ray.b[k] * v[k][2];
    w += ray.b[k] * v[k][3];
  }
  ray.zw = z / w;
  return ray;
}

// NDC of a point in pixel coordinates (px right, py down the rows), row 0 at the top.
inline double ndc_x(double px, int width) { return 2.0 * px / width - 1.0; }
inline double ndc_y(double py, int height) { return 1.0 - 2.0 * py / height; }

}  // namespace gr::testing
