#include "raster/mesh_framing.h"

#include <algorithm>
#include <cmath>

namespace gr::raster {

MeshFraming frame_mesh(const Mesh& mesh) {
  const float* p = mesh.positions.data<float>();
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[3 * i + a]));
      hi[a] = std::max(hi[a], double(p[3 * i + a]));
    }
  MeshFraming f;
  if (mesh.num_vertices() == 0) lo[0] = lo[1] = lo[2] = hi[0] = hi[1] = hi[2] = 0;
  double r2 = 0;
  for (int a = 0; a < 3; ++a) {
    f.centre[a] = 0.5 * (lo[a] + hi[a]);
    r2 += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
  }
  f.radius = r2 > 0 ? std::sqrt(r2) : 1.0;
  const double distance = f.radius / std::sin(f.fov_y / 2);  // the sphere touches the frustum
  const double dir[3] = {0.35, 0.25, 1.0};
  const double dir_len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (int a = 0; a < 3; ++a) f.eye[a] = f.centre[a] + distance * dir[a] / dir_len;
  f.near = 0.5 * (distance - f.radius);
  f.far = 2.0 * (distance + f.radius);
  return f;
}

}  // namespace gr::raster
