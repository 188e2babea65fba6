#include "mesh_framing.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "ops/ops.h"

namespace gr::bench {

Tensor frame_mesh(const raster::Mesh& mesh) {
  const float* p = mesh.positions.data<float>();
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[3 * i + a]));
      hi[a] = std::max(hi[a], double(p[3 * i + a]));
    }
  double centre[3], radius = 0;
  for (int a = 0; a < 3; ++a) {
    centre[a] = 0.5 * (lo[a] + hi[a]);
    radius += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
  }
  radius = std::sqrt(radius);  // half the box diagonal: a bounding sphere
  const double fov_y = 0.7;
  const double distance = radius / std::sin(fov_y / 2);  // the sphere touches the frustum
  const double dir[3] = {0.35, 0.25, 1.0};
  const double dir_len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  std::vector<double> eye(3);
  for (int a = 0; a < 3; ++a) eye[a] = centre[a] + distance * dir[a] / dir_len;
  gr::Tensor view = gr::look_at(gr::Tensor::from_values(eye, {3}),
                                gr::Tensor::from_values({centre[0], centre[1], centre[2]}, {3}),
                                gr::Tensor::from_values({0, 1, 0}, {3}));
  gr::Tensor proj = gr::perspective(fov_y, 1.0, 0.5 * (distance - radius), 2.0 * (distance + radius));
  return transform_points(mesh.positions, matmul(proj, view)).detach();
}

}  // namespace gr::bench
