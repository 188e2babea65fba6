#include "examples/common/mesh_framing.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "autodiff/base/error.h"

namespace gr::examples {

MeshFraming frame_mesh(const raster::Mesh& mesh) {
  const float* p = mesh.positions.data<float>();
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[3 * i + a]));
      hi[a] = std::max(hi[a], double(p[3 * i + a]));
    }
  if (mesh.num_vertices() == 0) throw ValueError("frame_mesh: the mesh has no vertices, nothing to frame");
  MeshFraming f;
  // Half the box diagonal, scaled by the largest extent so that the squares
  // neither underflow nor overflow.
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  if (!(extent > 0)) {
    char at[96];
    std::snprintf(at, sizeof at, "(%.9g, %.9g, %.9g)", lo[0], lo[1], lo[2]);
    throw ValueError("frame_mesh: all " + std::to_string(mesh.num_vertices()) + " vertices lie at one point " + at +
                     ": the mesh has no extent to frame");
  }
  double r2 = 0;
  for (int a = 0; a < 3; ++a) {
    f.centre[a] = 0.5 * (lo[a] + hi[a]);
    const double half = 0.5 * (hi[a] - lo[a]) / extent;
    r2 += half * half;
  }
  f.radius = extent * std::sqrt(r2);
  const double distance = f.radius / std::sin(f.fov_y / 2);  // the sphere touches the frustum
  const double dir[3] = {0.35, 0.25, 1.0};
  const double dir_len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (int a = 0; a < 3; ++a) f.eye[a] = f.centre[a] + distance * dir[a] / dir_len;
  f.near = 0.5 * (distance - f.radius);
  f.far = 2.0 * (distance + f.radius);
  return f;
}

}  // namespace gr::examples
