// The shading examples (examples/shading): hand-computed values of Lambert,
// Blinn-Phong, normal mapping, vertex tangents and SH irradiance, and their
// gradients against finite differences. Gradcheck inputs keep n.l and n.h
// above about 0.3, away from the kinks of max(., 0) and the n.l > 0 step.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/optim.h"
#include "examples/shading/shading.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {

constexpr double kPi = 3.14159265358979323846;

Tensor vec3(double x, double y, double z) { return Tensor::from_values({x, y, z}, {3}, DType::Float64); }

// base + uniform noise in [-spread, spread), a float64 leaf requiring grad.
Tensor around(const Tensor& base, double spread, std::uint64_t seed) {
  Tensor t = random_input(base.shape(), -spread, spread, seed);
  NoGradGuard no_grad;
  return (t + cast(base, DType::Float64)).copy().set_requires_grad();
}

// n unit directions spread evenly over the sphere (Fibonacci lattice), [n, 3] float64.
Tensor sphere_directions(int n) {
  std::vector<double> d;
  for (int i = 0; i < n; ++i) {
    const double y = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - y * y), phi = i * kPi * (3 - std::sqrt(5.0));
    d.insert(d.end(), {r * std::cos(phi), y, r * std::sin(phi)});
  }
  return Tensor::from_values(d, {n, 3}, DType::Float64);
}

double dot3(const Tensor& a, std::int64_t i, const Tensor& b) {
  return a.at({i, 0}) * b.at({0}) + a.at({i, 1}) * b.at({1}) + a.at({i, 2}) * b.at({2});
}

}  // namespace

TEST_CASE("shading: Lambert returns the albedo where the normal faces the light and 0 where it faces away",
          "[examples][shading]") {
  const Tensor albedo = vec3(0.2, 0.5, 0.9);
  const Tensor l = normalize(vec3(1, 2, -2));
  const Tensor facing = shading::lambert(albedo, l, l);
  const Tensor away = shading::lambert(albedo, -l, l);
  const Tensor oblique = shading::lambert(albedo, vec3(0, 0, 1), normalize(vec3(0, 1, 1)));  // cos 45
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(facing.at({c}) == Approx(albedo.at({c})).epsilon(1e-12));
    CHECK(away.at({c}) == 0.0);
    CHECK(oblique.at({c}) == Approx(albedo.at({c}) * std::sqrt(0.5)).epsilon(1e-12));
  }
}

TEST_CASE("shading: Lambert gradients w.r.t. albedo, normal and light match finite differences",
          "[examples][shading][gradcheck]") {
  // Components in [0.3, 1] keep n.l >= 0.27.
  const Tensor albedo = random_input({4, 5, 3}, 0.1, 0.9, 1);
  const Tensor normal = random_input({4, 5, 3}, 0.3, 1.0, 2);
  const Tensor light = random_input({3}, 0.3, 1.0, 3);
  require_gradcheck("shading::lambert", [](const std::vector<Tensor>& x) { return shading::lambert(x[0], x[1], x[2]); },
                    {albedo, normal, light});
}

TEST_CASE("shading: Blinn-Phong gives albedo + specular with light and eye on the normal, nothing lit from behind",
          "[examples][shading]") {
  const Tensor albedo = vec3(0.2, 0.4, 0.6), specular = vec3(0.5, 0.25, 0.125);
  const Tensor n = normalize(vec3(1, 1, 0)), p = vec3(0.5, -1, 2);
  const Tensor shininess = Tensor::scalar(32.0, DType::Float64);
  const Tensor head_on = shading::blinn_phong(albedo, n, p, p + 3.0 * n, p + 5.0 * n, shininess, specular);
  // Eye in front, light behind the surface: h can face n, but the n.l > 0 step removes the highlight.
  const Tensor behind = shading::blinn_phong(albedo, n, p, p - 3.0 * n + vec3(0, 0, 0.5), p + 5.0 * n, shininess,
                                             specular);
  // l = n and v = z, 90 degrees apart: h bisects them, n.h = cos 45, so albedo + specular cos(45)^32.
  const Tensor eye = p + vec3(0, 0, 1), light = p + n;
  const Tensor bisected = shading::blinn_phong(albedo, n, p, light, eye, shininess, specular);
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(head_on.at({c}) == Approx(albedo.at({c}) + specular.at({c})).epsilon(1e-12));
    CHECK(behind.at({c}) == 0.0);
    const double expected = albedo.at({c}) + specular.at({c}) * std::pow(std::cos(kPi / 4), 32);
    CHECK(bisected.at({c}) == Approx(expected).epsilon(1e-10));
  }
}

TEST_CASE("shading: Blinn-Phong gradients w.r.t. every input (shininess too) match finite differences",
          "[examples][shading][gradcheck]") {
  // Normals with components in [0.3, 1], points near the origin, light and eye
  // in the positive octant a few units away: n.l and n.h stay above 0.3.
  const Tensor albedo = random_input({3, 4, 3}, 0.1, 0.9, 11);
  const Tensor normal = random_input({3, 4, 3}, 0.3, 1.0, 12);
  const Tensor position = random_input({3, 4, 3}, -0.2, 0.2, 13);
  const Tensor light_pos = around(vec3(1, 2, 3), 0.3, 14);
  const Tensor eye_pos = around(vec3(3, 1, 2), 0.3, 15);
  const Tensor shininess = random_input({1}, 8, 12, 16);
  const Tensor specular = random_input({3, 4, 3}, 0.1, 0.9, 17);
  require_gradcheck("shading::blinn_phong",
                    [](const std::vector<Tensor>& x) {
                      return shading::blinn_phong(x[0], x[1], x[2], x[3], x[4], x[5], x[6]);
                    },
                    {albedo, normal, position, light_pos, eye_pos, shininess, specular});
}

TEST_CASE("shading: normal-map texel (.5, .5, 1) returns the normal, (1, .5, .5) the tangent, (.5, 1, .5) N x T",
          "[examples][shading]") {
  const Tensor normal = normalize(random_input({6, 3}, -1, 1, 21)).detach();
  const Tensor tangent = random_input({6, 3}, -1, 1, 22).detach();
  const Tensor flat = Tensor::from_values({0.5, 0.5, 1.0}, {3}, DType::Float64);
  const Tensor same = shading::perturb_normal(normal, tangent, flat);
  for (std::int64_t i = 0; i < 6; ++i)
    for (std::int64_t k = 0; k < 3; ++k) CHECK(same.at({i, k}) == Approx(normal.at({i, k})).margin(1e-12));

  // N = z, T = x + 0.5 z: Gram-Schmidt gives T = x, and B = z x x = y.
  const Tensor n = vec3(0, 0, 1), t = vec3(1, 0, 0.5);
  const Tensor to_t = shading::perturb_normal(n, t, vec3(1, 0.5, 0.5));
  const Tensor to_b = shading::perturb_normal(n, t, vec3(0.5, 1, 0.5));
  const Tensor tilted = shading::perturb_normal(n, t, vec3(0.75, 0.5, 0.75));  // m = (0.5, 0, 0.5)
  CHECK(to_t.at({0}) == Approx(1).epsilon(1e-15));
  CHECK(to_t.at({1}) == Approx(0).margin(1e-15));
  CHECK(to_t.at({2}) == Approx(0).margin(1e-15));
  CHECK(to_b.at({0}) == Approx(0).margin(1e-15));
  CHECK(to_b.at({1}) == Approx(1).epsilon(1e-15));
  CHECK(to_b.at({2}) == Approx(0).margin(1e-15));
  CHECK(tilted.at({0}) == Approx(std::sqrt(0.5)).epsilon(1e-12));
  CHECK(tilted.at({2}) == Approx(std::sqrt(0.5)).epsilon(1e-12));
}

TEST_CASE("shading: normal-mapping gradients w.r.t. normal, tangent and texel match finite differences",
          "[examples][shading][gradcheck]") {
  // Normals near +z, tangents near +x (never parallel), texels around a mild bump.
  const Tensor five = Tensor::ones({5, 1}, DType::Float64);
  const Tensor normal = around(vec3(0, 0, 1) * five, 0.3, 31);
  const Tensor tangent = around(vec3(1, 0, 0) * five, 0.3, 32);
  const Tensor texel = around(vec3(0.5, 0.5, 0.9) * five, 0.2, 33);
  require_gradcheck("shading::perturb_normal",
                    [](const std::vector<Tensor>& x) { return shading::perturb_normal(x[0], x[1], x[2]); },
                    {normal, tangent, texel});
}

TEST_CASE("shading: vertex tangents point along +u: +x on the plane, eastward and tangent to the UV sphere",
          "[examples][shading]") {
  const raster::Mesh plane = raster::make_plane(3, 2);
  const Tensor tp = shading::vertex_tangents(plane.positions, plane.uvs, plane.triangles);
  for (std::int64_t i = 0; i < plane.num_vertices(); ++i) {
    CHECK(tp.at({i, 0}) == Approx(1).epsilon(1e-6));
    CHECK(tp.at({i, 1}) == Approx(0).margin(1e-6));
    CHECK(tp.at({i, 2}) == Approx(0).margin(1e-6));
  }

  // Away from the poles every face tangent is a horizontal chord, so T is
  // horizontal, within a half cell (pi/16) of east = d/dphi (x = sin phi,
  // z = cos phi; the one-sided seam copies are off by that much), and
  // B = N x T points north (+v).
  const raster::Mesh sphere = raster::make_uv_sphere(8, 16);
  const Tensor ts = shading::vertex_tangents(sphere.positions, sphere.uvs, sphere.triangles);
  const Tensor b = cross(sphere.normals, ts);
  int checked = 0;
  for (std::int64_t i = 0; i < sphere.num_vertices(); ++i) {
    const double y = sphere.positions.at({i, 1});
    if (std::abs(y) > 0.99) continue;  // pole copies: one degenerate face each
    const double x = sphere.positions.at({i, 0}), z = sphere.positions.at({i, 2});
    const double r = std::hypot(x, z);
    CHECK(ts.at({i, 1}) == Approx(0).margin(1e-6));
    CHECK(ts.at({i, 0}) * z / r - ts.at({i, 2}) * x / r > std::cos(kPi / 16) - 1e-6);
    CHECK(b.at({i, 1}) > 0);
    ++checked;
  }
  CHECK(checked == 7 * 17);
}

TEST_CASE("shading: vertex tangent gradients w.r.t. positions and uvs match finite differences (plane, cube)",
          "[examples][shading][gradcheck]") {
  const std::pair<const char*, raster::Mesh> meshes[] = {{"plane", raster::make_plane(3, 2)},
                                                         {"cube", raster::make_cube(2.0f)}};
  for (const auto& [name, mesh] : meshes) {
    const Tensor p = around(mesh.positions, 0.1, 41);  // off the plane: a bumpy grid
    const Tensor uv = around(mesh.uvs, 0.05, 42);
    const Tensor triangles = mesh.triangles;
    require_gradcheck(std::string("shading::vertex_tangents (") + name + ")",
                      [triangles](const std::vector<Tensor>& x) {
                        return shading::vertex_tangents(x[0], x[1], triangles);
                      },
                      {p, uv});
  }
}

TEST_CASE("shading: SH with only a DC coefficient c gives constant irradiance pi Y00 c, and constant radiance L gives pi L",
          "[examples][shading]") {
  const Tensor n = sphere_directions(50);
  std::vector<double> dc(27, 0.0);
  dc[0] = 0.5, dc[1] = 1.0, dc[2] = 2.0;  // L00 per channel
  const Tensor e = shading::sh_irradiance(n, Tensor::from_values(dc, {9, 3}, DType::Float64));
  REQUIRE(e.shape() == Shape({50, 3}));
  for (std::int64_t i = 0; i < 50; ++i)
    for (std::int64_t c = 0; c < 3; ++c) CHECK(e.at({i, c}) == Approx(kPi * 0.282095 * dc[c]).epsilon(1e-12));

  // Radiance L everywhere: L00 = 4 pi Y00 L, E = A0 Y00 L00 = 4 pi^2 Y00^2 L = pi L (Y00^2 = 1 / 4 pi).
  const Tensor sky = shading::sh_sky_ground(vec3(0, 1, 0), vec3(0.3, 0.6, 0.9), vec3(0.3, 0.6, 0.9));
  const Tensor ec = shading::sh_irradiance(n, sky);
  for (std::int64_t i = 0; i < 50; ++i)
    for (std::int64_t c = 0; c < 3; ++c) CHECK(ec.at({i, c}) == Approx(kPi * 0.3 * (c + 1)).epsilon(1e-5));
}

TEST_CASE("shading: SH sky/ground irradiance is pi sky up, pi ground down and their mean at the horizon",
          "[examples][shading]") {
  const Tensor up = normalize(vec3(0.3, 1, -0.2));  // tilted, so every l = 1 coefficient is used
  const Tensor sky = vec3(1.0, 0.8, 0.6), ground = vec3(0.1, 0.2, 0.3);
  const Tensor sh = shading::sh_sky_ground(up, sky, ground);
  const Tensor horizon = normalize(cross(up, vec3(1, 0, 0)));
  const Tensor e_up = shading::sh_irradiance(up, sh), e_down = shading::sh_irradiance(-up, sh);
  const Tensor e_side = shading::sh_irradiance(horizon, sh);
  const Tensor albedo = vec3(0.5, 0.5, 0.5);
  const Tensor shade_up = shading::sh_diffuse(albedo, up, sh);
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(e_up.at({c}) == Approx(kPi * sky.at({c})).epsilon(1e-5));
    CHECK(e_down.at({c}) == Approx(kPi * ground.at({c})).epsilon(1e-5));
    CHECK(e_side.at({c}) == Approx(kPi * (sky.at({c}) + ground.at({c})) / 2).epsilon(1e-5));
    CHECK(shade_up.at({c}) == Approx(0.5 * sky.at({c})).epsilon(1e-5));  // albedo E / pi
  }
}

TEST_CASE("shading: SH of a directional light is rotation invariant, near the clamped cosine and largest at the light",
          "[examples][shading]") {
  // By the addition theorem E(n) = sum_l A_l (2l + 1) / (4 pi) P_l(cos t)
  //   = 1/4 + cos t / 2 + 5/16 P_2(cos t)   (E = 1.0625 at t = 0, 0.0625 at t = pi, 0.09375 at t = pi/2)
  // for ANY light direction: a wrong basis constant breaks this for a tilted light.
  const Tensor d = normalize(vec3(0.4, -0.7, 0.5));
  const Tensor sh = shading::sh_directional_light(d, vec3(1, 1, 1));
  const Tensor n = sphere_directions(400);
  const Tensor e = shading::sh_irradiance(n, sh);
  std::int64_t brightest = 0;
  double closest = -2;
  std::int64_t closest_i = 0;
  for (std::int64_t i = 0; i < 400; ++i) {
    const double c = dot3(n, i, d);
    const double expected = 0.25 + c / 2 + 5.0 / 16 * (3 * c * c - 1) / 2;
    CHECK(e.at({i, 0}) == Approx(expected).margin(1e-5));  // the constants have 6 digits
    CHECK(std::abs(e.at({i, 0}) - std::max(c, 0.0)) < 0.1);  // clamped cosine within 0.1 everywhere
    if (e.at({i, 0}) > e.at({brightest, 0})) brightest = i;
    if (c > closest) closest = c, closest_i = i;
  }
  CHECK(brightest == closest_i);
  const Tensor at_light = shading::sh_irradiance(d, sh);
  CHECK(at_light.at({0}) == Approx(1.0625).epsilon(1e-5));
  CHECK(shading::sh_irradiance(-d, sh).at({0}) == Approx(0.0625).margin(1e-5));
}

TEST_CASE("shading: SH gradients w.r.t. normals, coefficients, albedo and light inputs match finite differences",
          "[examples][shading][gradcheck]") {
  const Tensor normal = random_input({2, 3, 3}, -1, 1, 51);
  const Tensor sh = random_input({9, 3}, -1, 1, 52);
  const Tensor albedo = random_input({2, 3, 3}, 0.1, 0.9, 53);
  require_gradcheck("shading::sh_irradiance",
                    [](const std::vector<Tensor>& x) { return shading::sh_irradiance(x[0], x[1]); }, {normal, sh});
  require_gradcheck("shading::sh_diffuse",
                    [](const std::vector<Tensor>& x) { return shading::sh_diffuse(x[0], x[1], x[2]); },
                    {albedo, normal, sh});
  const Tensor d = random_input({3}, -1, 1, 54), colour = random_input({3}, 0, 1, 55);
  require_gradcheck("shading::sh_directional_light",
                    [](const std::vector<Tensor>& x) { return shading::sh_directional_light(x[0], x[1]); },
                    {d, colour});
  const Tensor up = random_input({3}, -1, 1, 56), sky = random_input({3}, 0, 1, 57),
               ground = random_input({3}, 0, 1, 58);
  require_gradcheck("shading::sh_sky_ground",
                    [](const std::vector<Tensor>& x) { return shading::sh_sky_ground(x[0], x[1], x[2]); },
                    {up, sky, ground});
}

TEST_CASE("shading: SH lighting can be fitted: Adam recovers 27 coefficients from shaded sphere samples",
          "[examples][shading]") {
  const Tensor n = sphere_directions(200);
  const Tensor albedo = vec3(0.8, 0.6, 0.4);
  const Tensor truth = shading::sh_sky_ground(normalize(vec3(0.2, 1, 0.1)), vec3(1.0, 0.9, 0.8), vec3(0.2, 0.15, 0.1)) +
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

TEST_CASE("shading: a loss on a rendered sphere sends finite gradients to normal map, SH light and vertices",
          "[examples][shading]") {
  const raster::Mesh mesh = raster::make_uv_sphere(8, 16);
  Tensor positions = mesh.positions.copy().set_requires_grad();
  Tensor normal_map = concat({Tensor::uniform({8, 16, 2}, 0.4, 0.6, 61), Tensor::ones({8, 16, 1})}, -1);
  normal_map.set_requires_grad();
  Tensor sh = shading::sh_sky_ground(normalize(Tensor::from_values({0.3, 1, 0}, {3})), Tensor::full({3}, 1.0),
                                     Tensor::full({3}, 0.2))
                  .copy()
                  .set_requires_grad();
  const Tensor view =
      look_at(Tensor::from_values({0, 0.5, 3}, {3}), Tensor::zeros({3}), Tensor::from_values({0, 1, 0}, {3}));
  const Tensor clip = transform_points(positions, matmul(perspective(0.8, 1.0, 0.1, 10.0), view));
  const GBuffer gb = rasterize(clip, mesh.triangles, {32, 32});
  const Tensor tangents = shading::vertex_tangents(positions, mesh.uvs, mesh.triangles);
  const Tensor normal = normalize(interpolate(mesh.normals, clip, gb, mesh.triangles));
  const Tensor tangent = interpolate(tangents, clip, gb, mesh.triangles);
  const Tensor texel = texture(normal_map, interpolate(mesh.uvs, clip, gb, mesh.triangles));
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
