// vertex_normals: against a loop over the definition (float64), pointing out
// of a sphere and up from a counter-clockwise grid, 0 at an isolated vertex,
// float64 finite differences on random meshes and on one with a hole, an
// isolated vertex, a degenerate face, a sliver and a fin.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"
#include "ops/mesh/mesh_cases.h"

using namespace gr;
using gr::testing::bumpy_icosphere_positions;
using gr::testing::grad_input;
using gr::testing::reference_mesh;
using gr::testing::require_gradcheck;

namespace {

// sum over faces at i of (p1 - p0) x (p2 - p0), normalized (0 stays 0).
std::vector<double> loop_normals(const Tensor& p, const Tensor& t) {
  std::vector<double> s(static_cast<std::size_t>(3 * p.size(0)), 0.0);
  for (std::int64_t f = 0; f < t.size(0); ++f) {
    std::int64_t c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::int64_t(t.at({f, k}));
    double u[3], v[3];
    for (int d = 0; d < 3; ++d) u[d] = p.at({c[1], d}) - p.at({c[0], d}), v[d] = p.at({c[2], d}) - p.at({c[0], d});
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) s[3 * c[k] + d] += n[d];
  }
  for (std::size_t i = 0; i < s.size(); i += 3) {
    const double len = std::sqrt(s[i] * s[i] + s[i + 1] * s[i + 1] + s[i + 2] * s[i + 2]);
    for (int d = 0; d < 3; ++d) s[i + d] = len > 0 ? s[i + d] / len : 0.0;
  }
  return s;
}

}  // namespace

TEST_CASE("vertex_normals: the normalized sums of the faces' cross products, out of a sphere, 0 where isolated",
          "[ops][mesh][vertex_normals]") {
  const raster::Mesh ico = raster::make_icosphere(2);
  const Tensor p = bumpy_icosphere_positions(ico, 0.05, 2);
  const std::vector<double> got = vertex_normals(p, ico.triangles).to_vector(), want = loop_normals(p, ico.triangles);
  for (std::size_t k = 0; k < want.size(); ++k) CHECK(got[k] == Approx(want[k]).margin(1e-14));
  // Unit sphere: the normal is nearly the position.
  const Tensor n = vertex_normals(ico.positions, ico.triangles);
  for (std::int64_t i = 0; i < ico.num_vertices(); ++i) {
    double along = 0;
    for (std::int64_t k = 0; k < 3; ++k) along += n.at({i, k}) * ico.positions.at({i, k});
    CHECK(along > 0.99);
  }
  // A counter-clockwise plane seen from +z: (0, 0, 1) everywhere.
  const raster::Mesh plane = raster::make_plane(3, 3);
  const Tensor up = vertex_normals(plane.positions, plane.triangles);
  for (std::int64_t i = 0; i < plane.num_vertices(); ++i) {
    CHECK(std::abs(up.at({i, 2})) == Approx(1.0).epsilon(1e-6));
    CHECK(up.at({i, 2}) == up.at({0, 2}));
  }
  // The hard mesh: its isolated vertex (index 42) gets 0, as does w of the degenerate face (a, w, w).
  const auto& hard = reference_mesh("hard");
  const Tensor h = vertex_normals(hard.positions, hard.triangles);
  for (std::int64_t k = 0; k < 3; ++k) {
    CHECK(h.at({42, k}) == 0);
    CHECK(h.at({43, k}) == 0);
  }
}

TEST_CASE("vertex_normals: gradients match float64 finite differences on random meshes and on a hard mesh",
          "[ops][mesh][vertex_normals][gradcheck]") {
  const raster::Mesh ico = raster::make_icosphere(1);
  for (std::uint64_t seed : {7u, 8u}) {
    const Tensor p = bumpy_icosphere_positions(ico, 0.1, seed);
    require_gradcheck("vertex_normals, random icosphere",
                      [&](const std::vector<Tensor>& in) { return vertex_normals(in[0], ico.triangles); },
                      {grad_input(p)});
  }
  // The hard mesh, weighted as generate.py does: 0 on the rows whose face normals sum to 0
  // (w of the degenerate face: its normal has no direction, its gradient is of order 1/eps).
  const auto& hard = reference_mesh("hard");
  const Tensor weight = Tensor::from_values(hard.value("vertex_normals weight"), {hard.positions.size(0), 3},
                                            DType::Float64);
  GradcheckOptions options;
  options.eps = 1e-6;  // the sliver is lifted 1e-3 off its edge (as in the Python tests)
  require_gradcheck("vertex_normals, hard mesh",
                    [&](const std::vector<Tensor>& in) { return vertex_normals(in[0], hard.triangles) * weight; },
                    {grad_input(hard.positions)}, options);
}
