#include <catch2/catch.hpp>

#include <cmath>

#include "autodiff/base/error.h"
#include "examples/common/mesh_framing.h"
#include "raster/procedural.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::examples;

namespace {

double distance(const std::array<double, 3>& a, const float* b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

}  // namespace

TEST_CASE("mesh framing: every vertex of an off-centre mesh lies inside the view cone and the depth range",
          "[raster][mesh_framing]") {
  Mesh mesh = make_torus(32, 12, 3.0f, 0.5f);
  float* p = mesh.positions.data<float>();
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i) {  // off the origin, stretched along y
    p[3 * i + 0] += 10.0f;
    p[3 * i + 1] = 2.0f * p[3 * i + 1] - 4.0f;
  }
  const MeshFraming f = frame_mesh(mesh);
  CHECK(f.centre[0] == Approx(10.0));
  CHECK(f.centre[1] == Approx(-4.0));
  const std::array<double, 3> axis{f.centre[0] - f.eye[0], f.centre[1] - f.eye[1], f.centre[2] - f.eye[2]};
  const double axis_len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i) {
    const float* v = p + 3 * i;
    const double to_v[3] = {v[0] - f.eye[0], v[1] - f.eye[1], v[2] - f.eye[2]};
    const double d = distance(f.eye, v);
    const double cos_angle = (to_v[0] * axis[0] + to_v[1] * axis[1] + to_v[2] * axis[2]) / (d * axis_len);
    INFO("vertex " << i);
    CHECK(std::acos(std::min(1.0, cos_angle)) <= f.fov_y / 2 + 1e-9);
    CHECK(d > f.near);
    CHECK(d < f.far);
  }
}

TEST_CASE("mesh framing: a mesh without vertices or with every vertex at one point is refused, naming the point",
          "[raster][mesh_framing]") {
  Mesh mesh = make_cube();
  float* p = mesh.positions.data<float>();
  for (std::int64_t i = 0; i < 3 * mesh.num_vertices(); ++i) p[i] = 5.0f;
  CHECK_THROWS_WITH(frame_mesh(mesh), Catch::Contains("vertices lie at one point (5, 5, 5)"));
  Mesh empty;
  empty.positions = Tensor::zeros({0, 3});
  empty.triangles = Tensor::zeros({0, 3}, DType::Int32);
  CHECK_THROWS_AS(frame_mesh(empty), ValueError);
}

TEST_CASE("mesh framing: a mesh of any representable size is framed at its own scale", "[raster][mesh_framing]") {
  const MeshFraming unit = frame_mesh(make_cube());
  for (float s : {1e-14f, 1e-30f, 1e30f}) {
    CAPTURE(s);
    Mesh mesh = make_cube();
    float* p = mesh.positions.data<float>();
    for (std::int64_t i = 0; i < 3 * mesh.num_vertices(); ++i) p[i] *= s;
    const MeshFraming f = frame_mesh(mesh);
    CHECK(f.radius == Approx(unit.radius * s).epsilon(1e-6));
    for (int a = 0; a < 3; ++a) CHECK(f.eye[a] == Approx(unit.eye[a] * s).epsilon(1e-6));
    CHECK(f.near == Approx(unit.near * s).epsilon(1e-6));
    CHECK(f.far == Approx(unit.far * s).epsilon(1e-6));
  }
}
