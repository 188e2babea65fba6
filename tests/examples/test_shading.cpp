// The shading example (examples/shading): its sky/ground SH environment
// (closed-form irradiance, gradients), fitting SH lighting with the library's
// functions, and the gallery's pipeline sending gradients to normal map, SH
// light and vertices. The library's shading functions have their own tests in
// tests/ops/shading/.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/optim.h"
#include "examples/shading/sky_ground.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::shading_example::sh_sky_ground;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {

constexpr double kPi = 3.14159265358979323846;

Tensor vec3(double x, double y, double z) { return Tensor::from_values({x, y, z}, {3}, DType::Float64); }

// n unit directions spread evenly over the sphere (Fibonacci lattice), [n, 3] float64.
Tensor sphere_directions(int n) {
  std::vector<double> d;
  for (int i = 0; i < n; ++i) {
    const double y = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - y * y), phi = i * kPi * (3 - std::sqrt(5.0));
    d.insert(d.end(), {r * std::cos(phi), y, r * std::sin(phi)});
  }
  return Tensor::from_values(d, {n, 3}, DType::Float64);
}

}  // namespace

TEST_CASE("shading example: constant sky and ground radiance L gives irradiance pi L everywhere",
          "[examples][shading]") {
  // L00 = 4 pi Y00 L, E = A0 Y00 L00 = 4 pi^2 Y00^2 L = pi L (Y00^2 = 1 / 4 pi).
  const Tensor n = sphere_directions(50);
  const Tensor sky = sh_sky_ground(vec3(0, 1, 0), vec3(0.3, 0.6, 0.9), vec3(0.3, 0.6, 0.9));
  REQUIRE(sky.shape() == Shape({9, 3}));
  const Tensor ec = shading::sh_irradiance(n, sky);
  for (std::int64_t i = 0; i < 50; ++i)
    for (std::int64_t c = 0; c < 3; ++c) CHECK(ec.at({i, c}) == Approx(kPi * 0.3 * (c + 1)).epsilon(1e-13));
}

TEST_CASE("shading example: sky/ground irradiance is pi sky up, pi ground down and their mean at the horizon",
          "[examples][shading]") {
  const Tensor up = normalize(vec3(0.3, 1, -0.2));  // tilted, so every l = 1 coefficient is used
  const Tensor sky = vec3(1.0, 0.8, 0.6), ground = vec3(0.1, 0.2, 0.3);
  const Tensor sh = sh_sky_ground(up, sky, ground);
  const Tensor horizon = normalize(cross(up, vec3(1, 0, 0)));
  const Tensor e_up = shading::sh_irradiance(up, sh), e_down = shading::sh_irradiance(-up, sh);
  const Tensor e_side = shading::sh_irradiance(horizon, sh);
  const Tensor albedo = vec3(0.5, 0.5, 0.5);
  const Tensor shade_up = shading::sh_diffuse(albedo, up, sh);
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(e_up.at({c}) == Approx(kPi * sky.at({c})).epsilon(1e-13));
    CHECK(e_down.at({c}) == Approx(kPi * ground.at({c})).epsilon(1e-13));
    CHECK(e_side.at({c}) == Approx(kPi * (sky.at({c}) + ground.at({c})) / 2).epsilon(1e-13));
    CHECK(shade_up.at({c}) == Approx(0.5 * sky.at({c})).epsilon(1e-13));  // albedo E / pi
  }
}

TEST_CASE("shading example: sky/ground gradients w.r.t. up, sky and ground match finite differences",
          "[examples][shading][gradcheck]") {
  const Tensor up = random_input({3}, -1, 1, 56), sky = random_input({3}, 0, 1, 57),
               ground = random_input({3}, 0, 1, 58);
  require_gradcheck("sh_sky_ground", [](const std::vector<Tensor>& x) { return sh_sky_ground(x[0], x[1], x[2]); },
                    {up, sky, ground});
}

TEST_CASE("shading example: SH lighting can be fitted: Adam recovers 27 coefficients from shaded sphere samples",
          "[examples][shading]") {
  const Tensor n = sphere_directions(200);
  const Tensor albedo = vec3(0.8, 0.6, 0.4);
  const Tensor truth = sh_sky_ground(normalize(vec3(0.2, 1, 0.1)), vec3(1.0, 0.9, 0.8), vec3(0.2, 0.15, 0.1)) +
                       shading::sh_directional_light(normalize(vec3(1, 0.5, 0.3)), vec3(2.0, 1.5, 1.0));
  const Tensor target = shading::sh_diffuse(albedo, n, truth);
  Tensor sh = Tensor::zeros({9, 3}, DType::Float64).set_requires_grad();
  Adam adam({sh}, {0.05});
  double first = 0, last = 0;
  for (int it = 0; it < 400; ++it) {
    const Tensor diff = shading::sh_diffuse(albedo, n, sh) - target;
    const Tensor loss = mean(diff * diff);
    (it == 0 ? first : last) = loss.item();
    backward(loss);
    adam.step();
    adam.zero_grad();
  }
  INFO("loss " << first << " -> " << last);
  CHECK(last < 1e-6 * first);
  // Irradiance is band-limited to l <= 2 and the samples cover the sphere, so the coefficients themselves come back.
  for (std::int64_t k = 0; k < 9; ++k)
    for (std::int64_t c = 0; c < 3; ++c) CHECK(sh.at({k, c}) == Approx(truth.at({k, c})).margin(2e-3));
}

TEST_CASE("shading example: a loss on a rendered sphere sends finite gradients to normal map, SH light and vertices",
          "[examples][shading]") {
  const raster::Mesh mesh = raster::make_uv_sphere(8, 16);
  Tensor positions = mesh.positions.copy().set_requires_grad();
  Tensor normal_map = concat({Tensor::uniform({8, 16, 2}, 0.4, 0.6, 61), Tensor::ones({8, 16, 1})}, -1);
  normal_map.set_requires_grad();
  Tensor sh = sh_sky_ground(normalize(Tensor::from_values({0.3, 1, 0}, {3})), Tensor::full({3}, 1.0),
                                     Tensor::full({3}, 0.2))
                  .copy()
                  .set_requires_grad();
  const Tensor view =
      look_at(Tensor::from_values({0, 0.5, 3}, {3}), Tensor::zeros({3}), Tensor::from_values({0, 1, 0}, {3}));
  const Tensor clip = transform_points(positions, matmul(perspective(0.8, 1.0, 0.1, 10.0), view));
  const GBuffer gb = rasterize(clip, mesh.triangles, {32, 32});
  const Tensor tangents = shading::vertex_tangents(positions, mesh.uvs, mesh.triangles, mesh.normals);
  const Tensor normal = normalize(interpolate(mesh.normals, gb, mesh.triangles));
  const Tensor tangent = interpolate(tangents, gb, mesh.triangles);
  const Tensor texel = texture(normal_map, interpolate(mesh.uvs, gb, mesh.triangles));
  const Tensor bumped = shading::perturb_normal(normal, tangent, texel);
  const Tensor colour = shading::sh_diffuse(Tensor::full({3}, 0.7), bumped, sh);
  backward(mean(colour * colour));
  for (const Tensor& t : {positions, normal_map, sh}) {
    REQUIRE(t.grad().defined());
    CHECK(gr::testing::all_finite(t.grad()));
    double largest = 0;
    for (double g : t.grad().to_vector()) largest = std::max(largest, std::abs(g));
    CHECK(largest > 0);
  }
}
