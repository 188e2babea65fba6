#include "peer_llvmpipe_scene.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "ops/linalg.h"
#include "ops/transforms.h"
#include "raster/obj_io.h"
#include "raster/procedural.h"

namespace peer {

gr::Tensor frame_mesh(const gr::raster::Mesh& mesh) {
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
  return gr::transform_points(mesh.positions, gr::matmul(proj, view));
}

std::vector<Scene> make_scenes(const std::string& mesh_path,
                               const std::function<bool(const std::string&)>& wanted,
                               std::vector<std::string>* notes) {
  gr::raster::Mesh base;
  std::string base_name;
  const std::string path = mesh_path.empty() ? kDefaultBunny : mesh_path;
  if (!mesh_path.empty() || std::ifstream(path).good()) {
    base = gr::raster::load_obj(path);  // an explicit --mesh that fails to load is an error
    base_name = mesh_path.empty() ? "bunny" : "mesh";
    notes->push_back("base mesh: " + path);
  } else {
    base = gr::raster::make_icosphere(6);
    base_name = "icosphere6";
    notes->push_back(std::string("base mesh: ") + kDefaultBunny +
                     " not found (install glmark2-data); using procedural icospheres instead");
  }
  std::vector<Scene> scenes;
  auto add = [&](const std::string& name, const gr::raster::Mesh& m) {
    if (wanted(name)) scenes.push_back({name, frame_mesh(m), m.triangles});
  };
  add("torus-10k", gr::raster::make_torus(100, 50, 1.0f, 0.35f));
  add(base_name, base);
  if (!wanted(base_name + "-x4") && !wanted(base_name + "-x16")) return scenes;
  gr::raster::Mesh x4 = gr::raster::subdivide(base);
  add(base_name + "-x4", x4);
  if (wanted(base_name + "-x16")) add(base_name + "-x16", gr::raster::subdivide(x4));
  return scenes;
}

}  // namespace peer
