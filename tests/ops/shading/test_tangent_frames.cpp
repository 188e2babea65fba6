// Tangent frames and normal mapping (ops/shading/tangent_frames.h): vertex
// tangents of known meshes (a quad with uv = (x, y) gives t = +x, w = +1;
// mirrored uvs give w = -1; an affine uv map gives dp/du; a vertex with only
// degenerate-uv faces gets t = 0, w = +1; a UV sphere's tangents point east),
// normal-map decoding, float64 gradchecks (random, mirrored, degenerate, zero
// tangent) and argument errors.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "raster/procedural.h"
#include "shading_cases.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using gr::testing::shading::kPi;
using gr::testing::shading::leaf;
using gr::testing::shading::unit_directions;
using gr::testing::shading::vec;
using gr::testing::shading::vec3;
using Inputs = std::vector<Tensor>;

namespace {

Tensor f64(const std::vector<double>& v, const Shape& s) { return Tensor::from_values(v, s, DType::Float64); }

// base (cast to float64) + uniform noise in [-spread, spread): a leaf requiring grad.
Tensor around(const Tensor& base, double spread, std::uint64_t seed) {
  NoGradGuard no_grad;
  return leaf(cast(base, DType::Float64) + Tensor::uniform(base.shape(), -spread, spread, seed, DType::Float64));
}

// The unit quad in z = 0 (normal +z) as two triangles; uvs given per vertex.
struct Quad {
  Tensor positions = f64({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, {4, 3});
  Tensor normals = f64({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, {4, 3});
  Tensor triangles = triangle_indices(std::vector<std::int64_t>{0, 1, 2, 0, 2, 3});
};

void check_tangent(const Tensor& t, std::int64_t i, double x, double y, double z, double w) {
  INFO("vertex " << i);
  CHECK(t.at({i, 0}) == Approx(x).margin(1e-15));
  CHECK(t.at({i, 1}) == Approx(y).margin(1e-15));
  CHECK(t.at({i, 2}) == Approx(z).margin(1e-15));
  CHECK(t.at({i, 3}) == w);
}

Tensor tangents_of(const Inputs& in, const Tensor& triangles) {
  return shading::vertex_tangents(in[0], in[1], triangles, in[2]);
}

}  // namespace

TEST_CASE("vertex_tangents: a quad with uv = (x, y) gets t = (1, 0, 0), w = +1 - mirrored u gets t = -x, w = -1",
          "[ops][shading][tangents]") {
  const Quad q;
  const Tensor t = shading::vertex_tangents(q.positions, f64({0, 0, 1, 0, 1, 1, 0, 1}, {4, 2}), q.triangles, q.normals);
  REQUIRE(t.shape() == Shape({4, 4}));
  for (std::int64_t i = 0; i < 4; ++i) check_tangent(t, i, 1, 0, 0, 1);
  const Tensor m = shading::vertex_tangents(q.positions, f64({1, 0, 0, 0, 0, 1, 1, 1}, {4, 2}), q.triangles, q.normals);
  for (std::int64_t i = 0; i < 4; ++i) check_tangent(m, i, -1, 0, 0, -1);
  // Mirrored v instead: t stays +x, but b = dp/dv = -y opposes n x t = +y.
  const Tensor mv = shading::vertex_tangents(q.positions, f64({0, 1, 1, 1, 1, 0, 0, 0}, {4, 2}), q.triangles, q.normals);
  for (std::int64_t i = 0; i < 4; ++i) check_tangent(mv, i, 1, 0, 0, -1);
}

TEST_CASE("vertex_tangents: a vertex whose faces all have degenerate uvs gets t = 0 and w = +1, its neighbours "
          "are unchanged",
          "[ops][shading][tangents]") {
  // Vertex 4 only belongs to triangle (1, 4, 2), whose uvs (1, 0), (1, 0), (1, 1) span no area.
  const Tensor positions = f64({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0.5, 0}, {5, 3});
  const Tensor normals = f64({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, {5, 3});
  const Tensor uvs = f64({0, 0, 1, 0, 1, 1, 0, 1, 1, 0}, {5, 2});
  const Tensor tris = triangle_indices(std::vector<std::int64_t>{0, 1, 2, 0, 2, 3, 1, 4, 2});
  const Tensor t = shading::vertex_tangents(positions, uvs, tris, normals);
  for (std::int64_t i = 0; i < 4; ++i) check_tangent(t, i, 1, 0, 0, 1);
  check_tangent(t, 4, 0, 0, 0, 1);
  // Gradients there stay finite (positions, normals; the uvs sit on a jump of sign(det)).
  const Tensor p = leaf(positions), n = leaf(normals);
  backward(sum(shading::vertex_tangents(p, uvs, tris, n)));
  CHECK((all_finite(p.grad()) && all_finite(n.grad())));
  require_gradcheck("vertex_tangents with a degenerate-uv vertex: positions, normals",
                    [&](const Inputs& in) { return shading::vertex_tangents(in[0], uvs, tris, in[1]); },
                    {around(positions, 0.05, 1), around(normals, 0.1, 2)});
}

TEST_CASE("vertex_tangents: an affine uv map (orientation kept or flipped) gives t = dp/du and its handedness",
          "[ops][shading][tangents]") {
  const raster::Mesh plane = raster::make_plane(3, 2);
  const Tensor xy = slice(cast(plane.positions, DType::Float64), 1, 0, 2);  // [V, 2]
  const Tensor x = slice(xy, 1, 0, 1), y = slice(xy, 1, 1, 2);
  const Tensor normals = cast(plane.normals, DType::Float64);
  // u = a x + b y, v = c x + d y: dp/du = (d, -c) / (ad - bc) in the plane, dp/dv = (-b, a) / (ad - bc).
  for (const auto& [a, b, c, d] : {std::array<double, 4>{2, 1, 0.5, 1.5}, std::array<double, 4>{-2, 1, 0.5, 1.5}}) {
    const double det = a * d - b * c;
    const Tensor uv = concat({a * x + b * y, c * x + d * y}, 1);
    const Tensor t = shading::vertex_tangents(cast(plane.positions, DType::Float64), uv, plane.triangles, normals);
    const double len = std::hypot(d, c), sign = det > 0 ? 1 : -1;
    for (std::int64_t i = 0; i < plane.num_vertices(); ++i) {
      INFO("det " << det << ", vertex " << i);
      CHECK(t.at({i, 0}) == Approx(sign * d / len).epsilon(1e-12));
      CHECK(t.at({i, 1}) == Approx(-sign * c / len).epsilon(1e-12));
      CHECK(t.at({i, 2}) == Approx(0).margin(1e-15));
      CHECK(t.at({i, 3}) == sign);  // cross(n, dp/du) . dp/dv = 1 / det
    }
  }
}

TEST_CASE("vertex_tangents: on a UV sphere t is orthogonal to n, within half a cell of east, and w = +1",
          "[ops][shading][tangents]") {
  const raster::Mesh sphere = raster::make_uv_sphere(8, 16);
  const Tensor t4 = shading::vertex_tangents(cast(sphere.positions, DType::Float64), cast(sphere.uvs, DType::Float64),
                                             sphere.triangles, cast(sphere.normals, DType::Float64));
  int checked = 0;
  for (std::int64_t i = 0; i < sphere.num_vertices(); ++i) {
    const double y = sphere.positions.at({i, 1});
    if (std::abs(y) > 0.99) continue;  // pole copies
    const double x = sphere.positions.at({i, 0}), z = sphere.positions.at({i, 2}), r = std::hypot(x, z);
    // The faces' dp/du are horizontal chords, but the triangles around a vertex are not symmetric east
    // and west, so their sum is up to half a cell (pi/16) off east = d/dphi (x = sin phi, z = cos phi),
    // and Gram-Schmidt against n then tilts it out of the horizontal by as much.
    CHECK(std::abs(t4.at({i, 1})) < std::sin(kPi / 16));
    CHECK(t4.at({i, 0}) * z / r - t4.at({i, 2}) * x / r > std::cos(kPi / 16) - 1e-6);
    double n_dot_t = 0;
    for (std::int64_t k = 0; k < 3; ++k) n_dot_t += sphere.normals.at({i, k}) * t4.at({i, k});
    CHECK(n_dot_t == Approx(0).margin(1e-6));
    CHECK(t4.at({i, 3}) == 1.0);
    ++checked;
  }
  CHECK(checked == 7 * 17);
}

TEST_CASE("vertex_tangents: gradients w.r.t. positions, uvs and normals match finite differences (plane, cube, "
          "mirrored cube)",
          "[ops][shading][tangents][gradcheck]") {
  raster::Mesh mirrored = raster::make_cube(2.0f);
  mirrored.uvs = concat({1.0 - slice(mirrored.uvs, 1, 0, 1), slice(mirrored.uvs, 1, 1, 2)}, 1);
  const std::pair<const char*, raster::Mesh> meshes[] = {
      {"plane", raster::make_plane(3, 2)}, {"cube", raster::make_cube(2.0f)}, {"mirrored cube", mirrored}};
  for (const auto& [name, mesh] : meshes) {
    const Tensor p = around(mesh.positions, 0.1, 41), uv = around(mesh.uvs, 0.05, 42);
    const Tensor n = around(mesh.normals, 0.1, 43);
    const Tensor triangles = mesh.triangles;
    if (std::string(name) == "mirrored cube") {
      const Tensor t = shading::vertex_tangents(p, uv, triangles, n);
      for (std::int64_t i = 0; i < mesh.num_vertices(); ++i) CHECK(t.at({i, 3}) == -1.0);
    }
    require_gradcheck(std::string("vertex_tangents (") + name + ")",
                      [triangles](const Inputs& in) { return tangents_of(in, triangles); }, {p, uv, n});
  }
}

TEST_CASE("perturb_normal: texel (.5, .5, 1) returns n, (1, .5, .5) the tangent, (.5, 1, .5) w n x t",
          "[ops][shading][tangents]") {
  const Tensor normal = unit_directions(6, 20);
  const Tensor tangent = concat({Tensor::uniform({6, 3}, -1, 1, 21, DType::Float64),
                                 f64({1, -1, 1, -1, 1, -1}, {6, 1})}, 1);
  const Tensor same = shading::perturb_normal(normal, tangent, vec3(0.5, 0.5, 1.0));
  for (std::int64_t i = 0; i < 6; ++i)
    for (std::int64_t k = 0; k < 3; ++k) CHECK(same.at({i, k}) == Approx(normal.at({i, k})).margin(1e-15));
  // n = z, tangent = x + 0.5 z: Gram-Schmidt gives t = x, and n x t = y.
  const Tensor n = vec3(0, 0, 1);
  for (double w : {1.0, -1.0}) {
    const Tensor t = vec({1, 0, 0.5, w});
    CHECK(shading::perturb_normal(n, t, vec3(1, 0.5, 0.5)).to_vector() == std::vector<double>{1, 0, 0});
    CHECK(shading::perturb_normal(n, t, vec3(0.5, 1, 0.5)).to_vector() == std::vector<double>{0, w, 0});
    const std::vector<double> tilted = shading::perturb_normal(n, t, vec3(0.75, 0.25, 0.75)).to_vector();
    CHECK(tilted[0] == Approx(1 / std::sqrt(3.0)).epsilon(1e-15));  // m = (0.5, -0.5, 0.5)
    CHECK(tilted[1] == Approx(-w / std::sqrt(3.0)).epsilon(1e-15));
    CHECK(tilted[2] == Approx(1 / std::sqrt(3.0)).epsilon(1e-15));
  }
}

TEST_CASE("perturb_normal: a zero-length tangent leaves the normal unperturbed, with finite gradients",
          "[ops][shading][tangents][gradcheck]") {
  const Tensor n = unit_directions(4, 30);
  const Tensor zero = f64({0, 0, 0, 1}, {4});
  const Tensor texel_up = concat({Tensor::uniform({4, 2}, 0, 1, 31, DType::Float64), Tensor::full({4, 1}, 0.9, DType::Float64)}, 1);
  const Tensor out = shading::perturb_normal(n, zero, texel_up);
  for (std::int64_t i = 0; i < 4; ++i)
    for (std::int64_t k = 0; k < 3; ++k) CHECK(out.at({i, k}) == Approx(n.at({i, k})).margin(1e-15));
  Tensor t = leaf(zero);
  backward(sum(shading::perturb_normal(n, t, texel_up)));
  CHECK(all_finite(t.grad()));
  require_gradcheck("perturb_normal, zero tangent: normal, texel",
                    [&](const Inputs& in) { return shading::perturb_normal(in[0], zero, in[1]); },
                    {leaf(n), leaf(texel_up)});
}

TEST_CASE("perturb_normal: gradients of normal, tangent (w included) and texel match finite differences",
          "[ops][shading][tangents][gradcheck]") {
  const Tensor five = Tensor::ones({5, 1}, DType::Float64);
  const Tensor normal = around(vec3(0, 0, 1) * five, 0.3, 51);
  const Tensor tangent = around(vec({1, 0, 0, 0}) * five, 0.3, 52);  // w in [-0.3, 0.3]: interpolated handedness
  const Tensor texel = around(vec3(0.5, 0.5, 0.9) * five, 0.3, 53);
  require_gradcheck("perturb_normal", [](const Inputs& in) { return shading::perturb_normal(in[0], in[1], in[2]); },
                    {normal, tangent, texel});
  const Tensor mirrored = around(vec({1, 0, 0, -1}) * five, 0.3, 54);
  require_gradcheck("perturb_normal mirrored, broadcast texel",
                    [](const Inputs& in) { return shading::perturb_normal(in[0], in[1], in[2]); },
                    {normal, mirrored, leaf(vec3(0.6, 0.3, 0.8))});
}

TEST_CASE("tangent frames: bad arguments are rejected naming them", "[ops][shading][tangents][errors]") {
  const Quad q;
  const Tensor uv = f64({0, 0, 1, 0, 1, 1, 0, 1}, {4, 2});
  CHECK_THROWS_WITH(shading::vertex_tangents(q.positions, Tensor::zeros({4, 3}, DType::Float64), q.triangles, q.normals),
                    Catch::Contains("shading::vertex_tangents") && Catch::Contains("'uvs'"));
  CHECK_THROWS_WITH(shading::vertex_tangents(q.positions, uv, q.triangles, Tensor::zeros({3, 3}, DType::Float64)),
                    Catch::Contains("'normals'"));
  CHECK_THROWS_WITH(shading::vertex_tangents(q.positions, cast(uv, DType::Float32), q.triangles, q.normals),
                    Catch::Contains("'uvs'") && Catch::Contains("dtype"));
  CHECK_THROWS_WITH(shading::vertex_tangents(Tensor::zeros({4, 2}, DType::Float64), uv, q.triangles, q.normals),
                    Catch::Contains("'positions'"));
  CHECK_THROWS_AS(shading::vertex_tangents(q.positions, uv, triangle_indices(std::vector<std::int64_t>{0, 1, 4}),
                                           q.normals),
                  IndexError);
  CHECK_THROWS_WITH(shading::vertex_tangents(q.positions, uv, cast(q.triangles, DType::Float64), q.normals),
                    Catch::Contains("'triangles'"));
  const Tensor n = Tensor::zeros({4, 3}, DType::Float64);
  CHECK_THROWS_WITH(shading::perturb_normal(n, n, n),
                    Catch::Contains("shading::perturb_normal") && Catch::Contains("'tangent'") &&
                        Catch::Contains("[..., 4]"));
  CHECK_THROWS_WITH(shading::perturb_normal(n, Tensor::zeros({4, 4}, DType::Float64), Tensor::zeros({4, 2}, DType::Float64)),
                    Catch::Contains("'texel'"));
  CHECK_THROWS_WITH(shading::perturb_normal(n, Tensor::zeros({4, 4}), n), Catch::Contains("'tangent'"));
}
