// Order-2 spherical harmonics (ops/shading/spherical_harmonics.h): the basis'
// exact constants and orthonormality, the irradiance of a constant and of a
// directional light against the addition theorem, float64 gradchecks of every
// input, shapes and argument errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "shading_cases.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using gr::testing::shading::kPi;
using gr::testing::shading::sphere_directions;
using gr::testing::shading::unit_directions;
using gr::testing::shading::vec;
using gr::testing::shading::vec3;
using Inputs = std::vector<Tensor>;

TEST_CASE("sh_basis: exact constants, e.g. Y00 = sqrt(1/4pi), Y10 = sqrt(3/4pi) z, Y20 = sqrt(5/16pi) (3z^2 - 1)",
          "[ops][shading][sh]") {
  const std::vector<double> up = shading::sh_basis(vec3(0, 0, 1)).to_vector();
  const std::vector<double> expected = {0.28209479177387814, 0, 0.48860251190291992, 0, 0, 0, 2 * 0.31539156525252005,
                                        0, 0};
  REQUIRE(up.size() == 9);
  for (std::size_t k = 0; k < 9; ++k) CHECK(up[k] == Approx(expected[k]).margin(1e-16).epsilon(1e-15));
  // (x, y, z) = (0.6, 0.8, 0): Y1-1 = c1 y, Y11 = c1 x, Y2-2 = c2 xy, Y22 = c22 (x^2 - y^2).
  const std::vector<double> b = shading::sh_basis(vec3(0.6, 0.8, 0)).to_vector();
  CHECK(b[1] == Approx(std::sqrt(3 / (4 * kPi)) * 0.8).epsilon(1e-15));
  CHECK(b[3] == Approx(std::sqrt(3 / (4 * kPi)) * 0.6).epsilon(1e-15));
  CHECK(b[4] == Approx(std::sqrt(15 / (4 * kPi)) * 0.48).epsilon(1e-15));
  CHECK(b[6] == Approx(-std::sqrt(5 / (16 * kPi))).epsilon(1e-15));
  CHECK(b[8] == Approx(std::sqrt(15 / (16 * kPi)) * (0.36 - 0.64)).epsilon(1e-14));
}

TEST_CASE("sh_basis: the 9 functions are orthonormal over the sphere (quadrature on 20000 points)",
          "[ops][shading][sh]") {
  const int n = 20000;
  const Tensor y = shading::sh_basis(sphere_directions(n));  // [n, 9]
  const Tensor gram = matmul(transpose(y), y) * (4 * kPi / n);
  for (std::int64_t i = 0; i < 9; ++i)
    for (std::int64_t j = 0; j < 9; ++j) CHECK(gram.at({i, j}) == Approx(i == j ? 1.0 : 0.0).margin(2e-3));
}

TEST_CASE("sh_irradiance: a DC coefficient c gives pi Y00 c everywhere, with any leading shape and channel count",
          "[ops][shading][sh]") {
  std::vector<double> dc(18, 0.0);
  dc[0] = 0.5, dc[1] = 2.0;  // L00 of two channels
  const Tensor sh = Tensor::from_values(dc, {9, 2}, DType::Float64);
  const Tensor n = reshape(unit_directions(24, 1), {2, 3, 4, 3});
  const Tensor e = shading::sh_irradiance(n, sh);
  REQUIRE(e.shape() == Shape({2, 3, 4, 2}));
  const std::vector<double> values = e.to_vector();
  for (std::size_t i = 0; i < values.size(); ++i)
    CHECK(values[i] == Approx(kPi * 0.28209479177387814 * dc[i % 2]).epsilon(1e-15));
}

TEST_CASE("sh_directional_light: irradiance is 1/4 + cos/2 + 5/16 P2(cos) for a tilted light, largest at the light",
          "[ops][shading][sh]") {
  // Addition theorem: E(n) = sum_l A_l (2l + 1) / (4 pi) P_l(cos t) for a unit light, whatever its direction.
  const Tensor d = vec3(0.4, -0.7, 0.5);  // not unit: sh_directional_light normalizes it
  const Tensor sh = shading::sh_directional_light(d, vec({1.0, 2.0}));
  REQUIRE(sh.shape() == Shape({9, 2}));
  const Tensor n = sphere_directions(300);
  const Tensor e = shading::sh_irradiance(n, sh);
  const Tensor cosine = dot(n, normalize(d));
  for (std::int64_t i = 0; i < 300; ++i) {
    const double c = cosine.at({i, 0}), expected = 0.25 + c / 2 + 5.0 / 16 * (3 * c * c - 1) / 2;
    CHECK(e.at({i, 0}) == Approx(expected).margin(1e-14));
    CHECK(e.at({i, 1}) == Approx(2 * expected).margin(2e-14));
    CHECK(std::abs(e.at({i, 0}) - std::max(c, 0.0)) < 0.1);  // near the clamped cosine
  }
  CHECK(shading::sh_irradiance(normalize(d), sh).at({0}) == Approx(1.0625).epsilon(1e-14));
}

TEST_CASE("sh_diffuse: albedo E / pi, the albedo broadcasting over pixels", "[ops][shading][sh]") {
  const Tensor sh = Tensor::uniform({9, 3}, -1, 1, 2, DType::Float64);
  const Tensor n = unit_directions(5, 3), albedo = vec3(0.2, 0.5, 0.8);
  const Tensor shaded = shading::sh_diffuse(albedo, n, sh), e = shading::sh_irradiance(n, sh);
  for (std::int64_t i = 0; i < 5; ++i)
    for (std::int64_t c = 0; c < 3; ++c)
      CHECK(shaded.at({i, c}) == Approx(albedo.at({c}) * e.at({i, c}) / kPi).epsilon(1e-15));
}

TEST_CASE("spherical harmonics: gradients of every input match finite differences", "[ops][shading][sh][gradcheck]") {
  require_gradcheck("sh_basis", [](const Inputs& in) { return shading::sh_basis(in[0]); },
                    {random_input({2, 5, 3}, -1, 1, 10)});
  const Tensor normal = random_input({2, 3, 3}, -1, 1, 11), sh = random_input({9, 3}, -1, 1, 12);
  require_gradcheck("sh_irradiance", [](const Inputs& in) { return shading::sh_irradiance(in[0], in[1]); },
                    {normal, sh});
  require_gradcheck("sh_diffuse", [](const Inputs& in) { return shading::sh_diffuse(in[0], in[1], in[2]); },
                    {random_input({3}, 0.1, 0.9, 13), normal, sh});
  require_gradcheck("sh_diffuse per pixel", [](const Inputs& in) { return shading::sh_diffuse(in[0], in[1], in[2]); },
                    {random_input({2, 3, 3}, 0.1, 0.9, 14), normal, sh});
  require_gradcheck("sh_directional_light",
                    [](const Inputs& in) { return shading::sh_directional_light(in[0], in[1]); },
                    {random_input({3}, -1, 1, 15), random_input({3}, 0, 2, 16)});
}

TEST_CASE("spherical harmonics: float32 works and keeps its dtype", "[ops][shading][sh]") {
  const Tensor sh = shading::sh_directional_light(Tensor::from_values({0, 1, 0}, {3}), Tensor::from_values({1}, {1}));
  const Tensor e = shading::sh_irradiance(Tensor::from_values({0, 1, 0}, {1, 3}), sh);
  CHECK(e.dtype() == DType::Float32);
  CHECK(e.item() == Approx(1.0625).epsilon(1e-6));
}

TEST_CASE("spherical harmonics: bad arguments are rejected naming them", "[ops][shading][sh][errors]") {
  const Tensor n = Tensor::zeros({4, 3}, DType::Float64), sh = Tensor::zeros({9, 3}, DType::Float64);
  CHECK_THROWS_WITH(shading::sh_basis(Tensor::zeros({4, 4}, DType::Float64)),
                    Catch::Contains("shading::sh_basis") && Catch::Contains("'direction'"));
  CHECK_THROWS_AS(shading::sh_irradiance(n, Tensor::zeros({8, 3}, DType::Float64)), ShapeError);
  CHECK_THROWS_WITH(shading::sh_irradiance(n, Tensor::zeros({8, 3}, DType::Float64)),
                    Catch::Contains("'sh'") && Catch::Contains("[9, C]"));
  CHECK_THROWS_WITH(shading::sh_irradiance(n, Tensor::zeros({9, 3})), Catch::Contains("'sh'") && Catch::Contains("dtype"));
  CHECK_THROWS_WITH(shading::sh_irradiance(Tensor::zeros({4, 2}, DType::Float64), sh), Catch::Contains("'normal'"));
  CHECK_THROWS_WITH(shading::sh_diffuse(Tensor::zeros({5, 3}, DType::Float64), n, sh),
                    Catch::Contains("shading::sh_diffuse") && Catch::Contains("'albedo'"));
  CHECK_THROWS_WITH(shading::sh_diffuse(Tensor::zeros({3}), n, sh), Catch::Contains("'albedo'"));
  CHECK_THROWS_WITH(shading::sh_diffuse(Tensor::zeros({3}, DType::Float64), n, Tensor::zeros({9})),
                    Catch::Contains("shading::sh_diffuse") && Catch::Contains("'sh'"));
  CHECK_THROWS_WITH(shading::sh_directional_light(n, vec3(1, 1, 1)), Catch::Contains("'direction'"));
  CHECK_THROWS_WITH(shading::sh_directional_light(vec3(0, 1, 0), Tensor::zeros({1, 3}, DType::Float64)),
                    Catch::Contains("'radiance'"));
}
