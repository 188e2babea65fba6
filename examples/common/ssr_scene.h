// The scene shared by the SSR tests, example and benchmarks: a glossy checker
// floor (the plane y = 0) with a red sphere, a blue sphere and a green box above
// it, seen by a camera slightly above the floor. World space, y up. Per-vertex
// colours and reflectivities ride along with the mesh; the spheres are also
// given analytically (centre, radius) so tests can intersect rays exactly.
#pragma once

#include <array>
#include <vector>

#include "autodiff/base/tensor.h"
#include "raster/mesh.h"

namespace gr::examples {

struct SsrSphere {
  std::array<double, 3> centre{};
  double radius = 1;
};

struct SsrScene {
  raster::Mesh mesh;          // world-space positions, normals, triangles (CCW seen from outside)
  Tensor colours;       // [N, 3] float32 albedo per vertex
  Tensor reflectivity;  // [N, 1] float32: the floor's value, 0 on the objects
  std::array<double, 3> eye{}, target{}, up{};
  double fov_y = 0, near = 0, far = 0;  // radians; OpenGL perspective
  double floor_y = 0;
  std::vector<SsrSphere> spheres;       // analytic copies of the sphere meshes
  std::array<double, 3> box_min{}, box_max{};  // the box, axis-aligned
};

// floor_cells: checker cells per side (each cell has its own 4 vertices, so the
// checker is crisp); sphere_subdivisions: icosphere level of the spheres.
SsrScene make_ssr_scene(int floor_cells = 8, int sphere_subdivisions = 4, float floor_reflectivity = 0.6f);

}  // namespace gr::examples
