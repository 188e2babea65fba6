#include "mesh_framing.h"

#include "ops/ops.h"
#include "examples/common/mesh_framing.h"

namespace gr::bench {

Tensor frame_mesh(const raster::Mesh& mesh) {
  const gr::examples::MeshFraming f = gr::examples::frame_mesh(mesh);
  auto vec = [](const std::array<double, 3>& v) { return gr::Tensor::from_values({v[0], v[1], v[2]}, {3}); };
  gr::Tensor view = gr::look_at(vec(f.eye), vec(f.centre), vec(f.up));
  gr::Tensor proj = gr::perspective(f.fov_y, 1.0, f.near, f.far);
  return transform_points(mesh.positions, matmul(proj, view)).detach();
}

}  // namespace gr::bench
