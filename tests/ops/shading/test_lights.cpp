// Lights (ops/shading/lights.h): directional and point light samples, the
// cube-map environment lookup and the reflected view direction: closed forms,
// float64 gradchecks (random, a point light 1e-3 from the surface, the light
// on the surface) and argument errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "shading_cases.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;
using gr::testing::shading::leaf;
using gr::testing::shading::unit_directions;
using gr::testing::shading::vec3;
using Inputs = std::vector<Tensor>;

namespace {
GradcheckOptions with_eps(double eps) {
  GradcheckOptions o;
  o.eps = eps;
  return o;
}
}  // namespace

TEST_CASE("directional_light: normalizes the direction and passes the radiance on", "[ops][shading][lights]") {
  const Tensor radiance = vec3(1, 2, 3);
  const shading::LightSample sun = shading::directional_light(vec3(0, 3, 4), radiance);
  CHECK(sun.direction.to_vector() == std::vector<double>{0, 0.6, 0.8});
  CHECK(sun.radiance.same(radiance));
  require_gradcheck("directional_light",
                    [](const Inputs& in) {
                      const shading::LightSample s = shading::directional_light(in[0], in[1]);
                      return concat({s.direction, s.radiance}, -1);
                    },
                    {random_input({5, 3}, -1, 1, 1), random_input({5, 2}, 0, 4, 2)});
}

TEST_CASE("point_light: direction to the light and intensity / distance^2", "[ops][shading][lights]") {
  const shading::LightSample lamp = shading::point_light(vec3(1, 2, 4), vec3(8, 4, 2), vec3(1, 2, 2));
  CHECK(lamp.direction.to_vector() == std::vector<double>{0, 0, 1});
  CHECK(lamp.radiance.to_vector() == std::vector<double>{2, 1, 0.5});
  // Per pixel: [2, 2, 3] positions lit by one light [3].
  const Tensor p = Tensor::from_values({0, 0, 0, 3, 0, 0, 0, -2, 0, 1, 1, 1}, {2, 2, 3}, DType::Float64);
  const shading::LightSample many = shading::point_light(vec3(0, 0, 0), vec3(1, 1, 1), p);
  REQUIRE(many.radiance.shape() == Shape({2, 2, 3}));
  CHECK(many.radiance.at({0, 1, 0}) == Approx(1.0 / 9).epsilon(1e-15));
  CHECK(many.radiance.at({1, 0, 2}) == Approx(0.25).epsilon(1e-15));
  CHECK(many.direction.at({1, 1, 0}) == Approx(-1 / std::sqrt(3.0)).epsilon(1e-15));
  // The light on the surface point: direction 0 and intensity / 1e-12, finite, with finite gradients.
  Tensor at = leaf(vec3(0.5, 0.5, 0.5)), intensity = leaf(vec3(1, 1, 1));
  const shading::LightSample on = shading::point_light(at, intensity, vec3(0.5, 0.5, 0.5));
  CHECK(on.direction.to_vector() == std::vector<double>{0, 0, 0});
  CHECK(on.radiance.at({0}) == Approx(1e12).epsilon(1e-12));
  backward(sum(on.radiance) + sum(on.direction));
  CHECK((all_finite(at.grad()) && all_finite(intensity.grad())));
}

TEST_CASE("point_light: gradients of light position, intensity and surface position match finite differences",
          "[ops][shading][lights][gradcheck]") {
  auto direction = [](const Inputs& in) { return shading::point_light(in[0], in[1], in[2]).direction; };
  auto radiance = [](const Inputs& in) { return shading::point_light(in[0], in[1], in[2]).radiance; };
  const Tensor light = leaf(vec3(1, 2, 3)), intensity = random_input({3}, 1, 5, 3);
  const Tensor position = random_input({4, 5, 3}, -1, 1, 4);
  require_gradcheck("point_light direction", direction, {light, intensity, position});
  require_gradcheck("point_light radiance", radiance, {light, intensity, position});
  // 1e-3 from the surface: the radiance is 1e6 intensity and varies on that scale.
  const Tensor close = leaf(vec3(0.3, 0.2, 0.1) + normalize(vec3(1, -2, 2)) * 1e-3);
  for (auto f : {+direction, +radiance})
    require_gradcheck("point_light 1e-3 from the surface", f, {close, intensity, leaf(vec3(0.3, 0.2, 0.1))},
                      with_eps(1e-8));
}

TEST_CASE("point_light: shading with its sample sends gradients to the light position (finite differences)",
          "[ops][shading][lights][gradcheck]") {
  const Tensor n = normalize(unit_directions(6, 5) * 0.3 + vec3(0, 0, 1));  // around +z, facing the light
  const Tensor v = normalize(vec3(0.2, -0.1, 1));
  require_gradcheck("cook_torrance under a point light",
                    [&](const Inputs& in) {
                      const shading::LightSample lamp = shading::point_light(in[0], in[1], in[2]);
                      return shading::cook_torrance(vec3(0.8, 0.6, 0.3), Tensor::scalar(0.2, DType::Float64),
                                                    Tensor::scalar(0.4, DType::Float64), n, lamp.direction, v) *
                             lamp.radiance;
                    },
                    {leaf(vec3(0.5, 1, 3)), leaf(vec3(10, 8, 6)), random_input({6, 3}, -0.5, 0.5, 6)});
}

TEST_CASE("environment_light: is the cube_texture lookup, returns a constant map's value, and has its gradients",
          "[ops][shading][lights][gradcheck]") {
  const Tensor map = random_input({6, 4, 4, 3}, 0, 2, 7);
  // Directions whose face coordinates sc/|ma|, tc/|ma| are 0.1, -0.6 or 0.3: at least 0.1 texel
  // from every bilinear cell boundary of a 4 x 4 face, so gradcheck's steps stay on one piece.
  const Tensor dir = leaf(Tensor::from_values({1, 0.1, -0.6, -0.5, 1.7, 0.51, 0.1, -0.6, -1, -2, 0.6, 0.2}, {4, 3},
                                              DType::Float64));
  CHECK(same_bits(shading::environment_light(map, dir), cube_texture(map, dir)));
  CubeTextureOptions nearest;
  nearest.filter = CubeFilter::Nearest;
  CHECK(same_bits(shading::environment_light(map, dir, nearest), cube_texture(map, dir, nearest)));
  for (double c : shading::environment_light(Tensor::full({6, 4, 4, 1}, 0.7, DType::Float64), unit_directions(20, 8))
                      .to_vector())
    CHECK(c == Approx(0.7).epsilon(1e-15));
  require_gradcheck("environment_light",
                    [](const Inputs& in) { return shading::environment_light(in[0], in[1]); }, {map, dir},
                    with_eps(1e-6));
}

TEST_CASE("reflect_view: 2 (n.v) n - v: the normal maps to itself, 45 degrees to the mirror side",
          "[ops][shading][lights]") {
  const Tensor n = normalize(vec3(0.3, -0.4, 1));
  CHECK(shading::reflect_view(n, n).to_vector()[2] == Approx(n.to_vector()[2]).epsilon(1e-15));
  const Tensor r = shading::reflect_view(normalize(vec3(1, 0, 1)), vec3(0, 0, 1));
  CHECK(r.at({0}) == Approx(-std::sqrt(0.5)).epsilon(1e-15));
  CHECK(r.at({1}) == 0.0);
  CHECK(r.at({2}) == Approx(std::sqrt(0.5)).epsilon(1e-15));
  const Tensor v = unit_directions(10, 9), normals = unit_directions(10, 10);
  const Tensor mirrored = shading::reflect_view(v, normals);
  const Tensor same_angle = dot(mirrored, normals) - dot(v, normals);
  const Tensor unit = length(mirrored) - 1.0;
  for (std::int64_t i = 0; i < 10; ++i) {
    CHECK(same_angle.at({i, 0}) == Approx(0).margin(1e-14));
    CHECK(unit.at({i, 0}) == Approx(0).margin(1e-14));
  }
  require_gradcheck("reflect_view", [](const Inputs& in) { return shading::reflect_view(in[0], in[1]); },
                    {random_input({3, 4, 3}, -1, 1, 11), random_input({4, 3}, -1, 1, 12)});
}

TEST_CASE("lights: bad arguments are rejected naming them", "[ops][shading][lights][errors]") {
  const Tensor v3 = Tensor::zeros({4, 3}, DType::Float64);
  CHECK_THROWS_WITH(shading::directional_light(Tensor::zeros({4, 2}, DType::Float64), v3),
                    Catch::Contains("shading::directional_light") && Catch::Contains("'direction'"));
  CHECK_THROWS_WITH(shading::directional_light(v3, Tensor::zeros({4, 3})), Catch::Contains("'radiance'"));
  CHECK_THROWS_WITH(shading::point_light(v3, v3, Tensor::zeros({5, 3}, DType::Float64)),
                    Catch::Contains("'position'") && Catch::Contains("broadcast"));
  CHECK_THROWS_WITH(shading::point_light(v3, Tensor::zeros({3}, DType::Int32), v3), Catch::Contains("'intensity'"));
  CHECK_THROWS_WITH(shading::point_light(v3, Tensor::zeros({5, 3}, DType::Float64), v3),
                    Catch::Contains("'intensity'") && Catch::Contains("broadcast"));
  CHECK_THROWS_AS(shading::environment_light(Tensor::zeros({5, 4, 4, 3}, DType::Float64), v3), ShapeError);
  CHECK_THROWS_WITH(shading::environment_light(Tensor::zeros({6, 4, 3, 3}, DType::Float64), v3),
                    Catch::Contains("shading::environment_light") && Catch::Contains("'cube_map'"));
  CHECK_THROWS_WITH(shading::environment_light(Tensor::zeros({6, 4, 4, 3}), v3), Catch::Contains("'direction'"));
  CHECK_THROWS_WITH(shading::environment_light(Tensor::zeros({6, 4, 4, 3}, DType::Float64),
                                               Tensor::zeros({4, 4}, DType::Float64)),
                    Catch::Contains("'direction'"));
  CHECK_THROWS_WITH(shading::reflect_view(v3, Tensor::zeros({3}, DType::Int32)), Catch::Contains("'normal'"));
}
