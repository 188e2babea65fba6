// make_ssr_scene: builds the floor, spheres and box into one mesh with per-vertex
// colours and reflectivities (examples/common/ssr_scene.h).
#include "examples/common/ssr_scene.h"

#include <cmath>
#include <cstdint>

#include "autodiff/base/error.h"
#include "raster/procedural.h"

namespace gr::examples {

using raster::make_cube;
using raster::make_icosphere;
using raster::Mesh;

namespace {

struct Accum {
  std::vector<float> pos, nrm, col, refl;
  std::vector<std::int32_t> tri;

  // Appends `m` scaled by s and moved by t, with one colour and reflectivity.
  void add(const Mesh& m, float s, const std::array<double, 3>& t, const std::array<float, 3>& c, float r) {
    const auto base = static_cast<std::int32_t>(pos.size() / 3);
    const auto p = m.positions.to_vector(), n = m.normals.to_vector();
    for (std::int64_t v = 0; v < m.num_vertices(); ++v) {
      for (int a = 0; a < 3; ++a) {
        pos.push_back(static_cast<float>(s * p[3 * v + a] + t[a]));
        nrm.push_back(static_cast<float>(n[3 * v + a]));
        col.push_back(c[a]);
      }
      refl.push_back(r);
    }
    for (double i : m.triangles.to_vector()) tri.push_back(base + static_cast<std::int32_t>(i));
  }
};

}  // namespace

SsrScene make_ssr_scene(int floor_cells, int sphere_subdivisions, float floor_reflectivity) {
  if (floor_cells < 1 || floor_cells > 512) throw ValueError("make_ssr_scene: floor_cells must be in 1..512");
  if (sphere_subdivisions < 0 || sphere_subdivisions > 6)
    throw ValueError("make_ssr_scene: sphere_subdivisions must be in 0..6");
  SsrScene scene;
  Accum acc;
  // Floor: the plane y = 0, side 8, facing +y; every checker cell has its own vertices.
  const float side = 8.0f, cell = side / floor_cells;
  for (int cz = 0; cz < floor_cells; ++cz)
    for (int cx = 0; cx < floor_cells; ++cx) {
      const float x0 = -side / 2 + cx * cell, z0 = -side / 2 + cz * cell;
      const float g = ((cx + cz) & 1) ? 0.85f : 0.25f;
      const auto base = static_cast<std::int32_t>(acc.pos.size() / 3);
      const float xs[4] = {x0, x0 + cell, x0 + cell, x0}, zs[4] = {z0, z0, z0 + cell, z0 + cell};
      for (int k = 0; k < 4; ++k) {
        acc.pos.insert(acc.pos.end(), {xs[k], 0.0f, zs[k]});
        acc.nrm.insert(acc.nrm.end(), {0.0f, 1.0f, 0.0f});
        acc.col.insert(acc.col.end(), {g, g, 0.95f * g + 0.05f});
        acc.refl.push_back(floor_reflectivity);
      }
      // Counter-clockwise seen from above (+y): (x0,z0+c) -> (x0+c,z0+c) -> (x0+c,z0) ...
      acc.tri.insert(acc.tri.end(), {base, base + 3, base + 2, base, base + 2, base + 1});
    }
  // Objects above the floor.
  scene.spheres = {{{0.0, 0.75, 0.0}, 0.55}, {{-1.45, 0.5, -0.6}, 0.4}};
  const Mesh sphere = make_icosphere(sphere_subdivisions, 1.0f);
  acc.add(sphere, float(scene.spheres[0].radius), scene.spheres[0].centre, {0.9f, 0.15f, 0.1f}, 0.0f);
  acc.add(sphere, float(scene.spheres[1].radius), scene.spheres[1].centre, {0.15f, 0.3f, 0.9f}, 0.0f);
  const float box = 0.7f;
  const std::array<double, 3> box_centre{1.35, 0.35 + 0.15, -0.5};
  acc.add(make_cube(box), 1.0f, box_centre, {0.2f, 0.8f, 0.25f}, 0.0f);
  for (int a = 0; a < 3; ++a) {
    scene.box_min[a] = box_centre[a] - box / 2;
    scene.box_max[a] = box_centre[a] + box / 2;
  }

  const auto n = static_cast<std::int64_t>(acc.pos.size() / 3);
  scene.mesh.positions = Tensor::from_vector(acc.pos, {n, 3});
  scene.mesh.normals = Tensor::from_vector(acc.nrm, {n, 3});
  scene.mesh.triangles = Tensor::from_vector(acc.tri, {static_cast<std::int64_t>(acc.tri.size() / 3), 3});
  scene.colours = Tensor::from_vector(acc.col, {n, 3});
  scene.reflectivity = Tensor::from_vector(acc.refl, {n, 1});
  scene.eye = {0.0, 1.3, 4.6};
  scene.target = {0.0, 0.35, 0.0};
  scene.up = {0.0, 1.0, 0.0};
  scene.fov_y = 45.0 * 3.14159265358979323846 / 180.0;
  scene.near = 0.1;
  scene.far = 30.0;
  scene.floor_y = 0;
  return scene;
}

}  // namespace gr::examples
