// BRDFs (ops/shading/brdf.h): closed forms (Lambert's cosine, Blinn-Phong's
// highlight, D(1) = 1/(pi alpha^2) and D's normalization, the Smith
// visibility against Heitz's Lambda form, Schlick's end points, Cook-Torrance
// at normal incidence), float64 gradchecks of every input on random and hard
// cases (grazing light, n.v at its 1e-4 clamp, roughness at and near 0.03 and
// 1, metallic 0 and 1, a sharp highlight), and argument errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "shading_cases.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using gr::testing::shading::at_angle;
using gr::testing::shading::kPi;
using gr::testing::shading::leaf;
using gr::testing::shading::unit_directions;
using gr::testing::shading::vec;
using gr::testing::shading::vec3;
using Inputs = std::vector<Tensor>;

namespace {

// n rows of a lit configuration: unit normals, and light and view directions
// with n.l and n.v in [lo, hi] (so no clamp or kink is near), all leaves.
struct Scene {
  Tensor normal, light, view;
};
Scene lit_scene(std::int64_t n, double lo, double hi, std::uint64_t seed) {
  const Tensor normal = unit_directions(n, seed);
  const Tensor light = at_angle(normal, unit_directions(n, seed + 1), Tensor::uniform({n, 1}, lo, hi, seed + 2, DType::Float64));
  const Tensor view = at_angle(normal, unit_directions(n, seed + 3), Tensor::uniform({n, 1}, lo, hi, seed + 4, DType::Float64));
  return {leaf(normal), leaf(light), leaf(view)};
}

Tensor scalar_column(double value) { return Tensor::full({1, 1}, value, DType::Float64); }

GradcheckOptions with_eps(double eps) {
  GradcheckOptions o;
  o.eps = eps;
  return o;
}

Tensor cook_torrance_of(const Inputs& in) { return shading::cook_torrance(in[0], in[1], in[2], in[3], in[4], in[5]); }
Tensor blinn_phong_of(const Inputs& in) { return shading::blinn_phong(in[0], in[1], in[2], in[3], in[4], in[5]); }

}  // namespace

// --- Lambert -----------------------------------------------------------------

TEST_CASE("lambert: albedo / pi facing the light, 0 facing away, cos(45) albedo / pi at 45 degrees",
          "[ops][shading][brdf]") {
  const Tensor albedo = vec3(0.2, 0.5, 0.9);
  const Tensor l = normalize(vec3(1, 2, -2));
  const Tensor facing = shading::lambert(albedo, l, l);
  const Tensor away = shading::lambert(albedo, -l, l);
  const Tensor oblique = shading::lambert(albedo, vec3(0, 0, 1), normalize(vec3(0, 1, 1)));
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(facing.at({c}) == Approx(albedo.at({c}) / kPi).epsilon(1e-15));
    CHECK(away.at({c}) == 0.0);
    CHECK(oblique.at({c}) == Approx(albedo.at({c}) * std::sqrt(0.5) / kPi).epsilon(1e-15));
  }
}

TEST_CASE("lambert: gradients of albedo, normal and a broadcast light match finite differences",
          "[ops][shading][brdf][gradcheck]") {
  const Tensor albedo = random_input({4, 5, 3}, 0.1, 0.9, 1);
  const Tensor normal = leaf(reshape(unit_directions(20, 2), {4, 5, 3}));
  const Tensor light = leaf(normalize(vec3(0.3, -0.5, 0.8)));  // lights some pixels, not others
  require_gradcheck("lambert", [](const Inputs& in) { return shading::lambert(in[0], in[1], in[2]); },
                    {albedo, normal, light}, with_eps(1e-6));
}

TEST_CASE("lambert: gradients match finite differences at grazing light just above and below the horizon",
          "[ops][shading][brdf][gradcheck]") {
  const Tensor n = normalize(vec3(0.2, 0.1, 1));
  for (double c : {1e-3, -1e-3}) {
    const Tensor l = at_angle(n, vec3(1, 0, 0), c);
    require_gradcheck("lambert grazing", [](const Inputs& in) { return shading::lambert(in[0], in[1], in[2]); },
                      {leaf(vec3(0.3, 0.6, 0.9)), leaf(n), leaf(l)}, with_eps(1e-6));
  }
  // Exactly on the horizon: value 0, finite gradients (the kink's gradient is split).
  Tensor n0 = leaf(vec3(0, 0, 1)), l0 = leaf(vec3(1, 0, 0)), a0 = leaf(vec3(0.3, 0.6, 0.9));
  const Tensor y = shading::lambert(a0, n0, l0);
  CHECK(sum(y.detach()).item() == 0.0);
  backward(sum(y));
  CHECK((all_finite(n0.grad()) && all_finite(l0.grad()) && all_finite(a0.grad())));
}

// --- Blinn-Phong -------------------------------------------------------------

TEST_CASE("blinn_phong: albedo / pi + specular head-on, nothing lit from behind, cos(45)^s at a bisected angle",
          "[ops][shading][brdf]") {
  const Tensor albedo = vec3(0.2, 0.4, 0.6), specular = vec3(0.5, 0.25, 0.125);
  const Tensor s = scalar_column(32.0);
  const Tensor n = normalize(vec3(1, 1, 0));
  const Tensor head_on = shading::blinn_phong(albedo, specular, s, n, n, n);
  // Eye in front, light behind: h can face n, but the n.l > 0 step removes the highlight.
  const Tensor behind = shading::blinn_phong(albedo, specular, s, n, at_angle(n, vec3(0, 0, 1), -0.1), n);
  // l = n and v = z, 90 degrees apart: n.h = cos 45.
  const Tensor bisected = shading::blinn_phong(albedo, specular, s, n, n, vec3(0, 0, 1));
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(head_on.at({0, c}) == Approx(albedo.at({c}) / kPi + specular.at({c})).epsilon(1e-15));
    CHECK(behind.at({0, c}) == 0.0);
    CHECK(bisected.at({0, c}) == Approx(albedo.at({c}) / kPi + specular.at({c}) * std::pow(std::sqrt(0.5), 32))
                                     .epsilon(1e-13));
  }
}

TEST_CASE("blinn_phong: gradients of every input (shininess included) match finite differences",
          "[ops][shading][brdf][gradcheck]") {
  const Scene s = lit_scene(12, 0.2, 0.95, 10);
  const Tensor albedo = random_input({12, 3}, 0.1, 0.9, 20), specular = random_input({12, 3}, 0.1, 0.9, 21);
  const Tensor shininess = random_input({12, 1}, 1, 60, 22);
  require_gradcheck("blinn_phong", blinn_phong_of, {albedo, specular, shininess, s.normal, s.light, s.view});
  // A scalar shininess and a light [3] shared by all pixels, some of them lit from behind.
  const Tensor normal = leaf(unit_directions(10, 23));
  require_gradcheck("blinn_phong broadcast", blinn_phong_of,
                    {random_input({10, 3}, 0.1, 0.9, 24), leaf(vec3(0.3, 0.3, 0.3)),
                     leaf(Tensor::scalar(8.0, DType::Float64)), normal, leaf(normalize(vec3(0.2, 0.9, 0.3))),
                     leaf(normalize(vec3(-0.3, 0.5, 0.8)))},
                    with_eps(1e-6));
}

TEST_CASE("blinn_phong: gradients match finite differences at grazing light and with a highlight at n.h -> 0",
          "[ops][shading][brdf][gradcheck]") {
  const Tensor n = vec3(0, 0, 1);
  const Tensor albedo = vec3(0.4, 0.5, 0.6), specular = vec3(0.3, 0.2, 0.1);
  const Tensor v = at_angle(n, vec3(1, 0, 0), 0.6);
  for (double c : {1e-3, -1e-3}) {
    require_gradcheck("blinn_phong grazing", blinn_phong_of,
                      {leaf(albedo), leaf(specular), leaf(scalar_column(20.0)), leaf(n),
                       leaf(at_angle(n, vec3(-1, 0.2, 0), c)), leaf(v)},
                      with_eps(1e-6));
  }
  // l and v nearly opposite and both near the horizon: n.h small, shininess 1.5.
  require_gradcheck("blinn_phong small n.h", blinn_phong_of,
                    {leaf(albedo), leaf(specular), leaf(scalar_column(1.5)), leaf(n),
                     leaf(at_angle(n, vec3(-1, 0, 0), 0.05)), leaf(at_angle(n, vec3(1, 0.01, 0), 0.04))},
                    with_eps(1e-6));
}

// --- GGX, Smith, Schlick -------------------------------------------------------

TEST_CASE("ggx_distribution: D(1) = 1/(pi alpha^2), D = 1/pi for alpha = 1, and D(h) (n.h) integrates to 1",
          "[ops][shading][brdf]") {
  for (double alpha : {0.05, 0.3, 0.7, 1.0}) {
    // (alpha^2 - 1) + 1 rounds to alpha^2 within about 1e-16 / alpha^2 (relative).
    CHECK(shading::ggx_distribution(vec({1.0}), vec({alpha})).item() ==
          Approx(1 / (kPi * alpha * alpha)).epsilon(1e-12));
    // integral over the hemisphere of D(mu) mu dw = 2 pi integral_0^1 D(mu) mu dmu (midpoint rule).
    const int steps = 400000;
    std::vector<double> mu(steps);
    for (int i = 0; i < steps; ++i) mu[static_cast<std::size_t>(i)] = (i + 0.5) / steps;
    const Tensor m = Tensor::from_values(mu, {steps}, DType::Float64);
    const double integral = 2 * kPi * sum(shading::ggx_distribution(m, vec({alpha})) * m).item() / steps;
    CHECK(integral == Approx(1.0).epsilon(1e-6));
  }
  const Tensor any = vec({0.0, 0.3, 0.8, 1.0});
  for (double d : shading::ggx_distribution(any, vec({1.0})).to_vector()) CHECK(d == Approx(1 / kPi).epsilon(1e-15));
}

TEST_CASE("smith_ggx_correlated: equals 1 / (4 n.l n.v (1 + Lambda_v + Lambda_l)) with Heitz's GGX Lambda",
          "[ops][shading][brdf]") {
  // Heitz 2014, eqs. 72 and 99: Lambda(mu) = (-1 + sqrt(1 + alpha^2 (1 - mu^2) / mu^2)) / 2, G2 = 1 / (1 + Lv + Ll).
  const Tensor nv = Tensor::uniform({50}, 0.01, 1, 1, DType::Float64);
  const Tensor nl = Tensor::uniform({50}, 0.01, 1, 2, DType::Float64);
  const Tensor alpha = Tensor::uniform({50}, 0.01, 1, 3, DType::Float64);
  const std::vector<double> v = shading::smith_ggx_correlated(nv, nl, alpha).to_vector();
  for (std::int64_t i = 0; i < 50; ++i) {
    const double a = alpha.at({i}), mv = nv.at({i}), ml = nl.at({i});
    auto lambda = [a](double mu) { return (-1 + std::sqrt(1 + a * a * (1 - mu * mu) / (mu * mu))) / 2; };
    CHECK(v[static_cast<std::size_t>(i)] == Approx(1 / (4 * ml * mv * (1 + lambda(mv) + lambda(ml)))).epsilon(1e-12));
  }
  CHECK(shading::smith_ggx_correlated(vec({1.0}), vec({1.0}), vec({0.37})).item() == Approx(0.25).epsilon(1e-15));
  CHECK(shading::smith_ggx_correlated(vec({0.3}), vec({0.6}), vec({1.0})).item() == Approx(0.5 / 0.9).epsilon(1e-15));
}

TEST_CASE("fresnel_schlick: f0 at normal incidence, 1 at grazing, f0 + (1 - f0)/32 at cos = 1/2",
          "[ops][shading][brdf]") {
  const Tensor f0 = vec3(0.04, 0.5, 0.95);
  const Tensor normal = shading::fresnel_schlick(vec({1.0}), f0);
  const Tensor grazing = shading::fresnel_schlick(vec({0.0}), f0);
  const Tensor half = shading::fresnel_schlick(vec({0.5}), f0);
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(normal.at({c}) == f0.at({c}));
    CHECK(grazing.at({c}) == Approx(1.0).epsilon(1e-15));
    CHECK(half.at({c}) == Approx(f0.at({c}) + (1 - f0.at({c})) / 32).epsilon(1e-15));
  }
}

TEST_CASE("ggx, smith and schlick: gradients match finite differences, random and at their extremes",
          "[ops][shading][brdf][gradcheck]") {
  require_gradcheck("ggx_distribution",
                    [](const Inputs& in) { return shading::ggx_distribution(in[0], in[1]); },
                    {random_input({20, 1}, 0, 1, 31), random_input({20, 1}, 0.03, 1, 32)});
  // The peak at the smallest alpha cook_torrance uses: about alpha^2 = 8e-7 wide in n_dot_h.
  // n_dot_h moves d = n_dot_h^2 (alpha^2 - 1) + 1 to first order (step 1e-10); alpha only
  // through alpha^2 (step 1e-6, so the formula's rounding stays below the tolerance).
  const Tensor peak_nh = vec({1.0, 0.9999995, 0.99999}), peak_alpha = vec({0.0009, 0.0009, 0.0009});
  require_gradcheck("ggx_distribution peak, n_dot_h",
                    [](const Inputs& in) { return shading::ggx_distribution(in[0], in[1]); },
                    {leaf(peak_nh), peak_alpha}, with_eps(1e-10));
  require_gradcheck("ggx_distribution peak, alpha",
                    [](const Inputs& in) { return shading::ggx_distribution(in[0], in[1]); },
                    {peak_nh, leaf(peak_alpha)}, with_eps(1e-6));
  require_gradcheck("smith_ggx_correlated",
                    [](const Inputs& in) { return shading::smith_ggx_correlated(in[0], in[1], in[2]); },
                    {random_input({20, 1}, 0, 1, 33), random_input({20, 1}, 0, 1, 34), random_input({20, 1}, 0.03, 1, 35)});
  // One case per call: V spans 0.5 to 700 here, and the largest one's rounding would swamp the others' steps.
  for (const std::vector<double>& c : {std::vector<double>{1e-4, 0.7, 0.0009}, {1e-4, 0.0, 0.5}, {0.5, 0.0, 1.0}})
    require_gradcheck("smith_ggx_correlated at n.v = 1e-4 or n.l = 0",
                      [](const Inputs& in) { return shading::smith_ggx_correlated(in[0], in[1], in[2]); },
                      {leaf(vec({c[0]})), leaf(vec({c[1]})), leaf(vec({c[2]}))}, with_eps(1e-7));
  require_gradcheck("fresnel_schlick", [](const Inputs& in) { return shading::fresnel_schlick(in[0], in[1]); },
                    {random_input({10, 1}, 0, 1, 36), random_input({10, 3}, 0, 1, 37)});
  require_gradcheck("fresnel_schlick at cos 0 and 1",
                    [](const Inputs& in) { return shading::fresnel_schlick(in[0], in[1]); },
                    {leaf(vec({0.0, 1.0})), leaf(vec({0.04, 0.9}))}, with_eps(1e-6));
}

// --- Cook-Torrance -----------------------------------------------------------

TEST_CASE("cook_torrance: at normal incidence metal gives base / (4 pi alpha^2) and a dielectric adds 0.96 base / pi",
          "[ops][shading][brdf]") {
  const Tensor n = normalize(vec3(0.2, 0.3, 1.0));
  const Tensor base = vec3(0.9, 0.6, 0.3);
  for (double roughness : {0.2, 0.5, 1.0}) {
    const double a2 = std::pow(roughness, 4);  // alpha = roughness^2
    const Tensor metal = shading::cook_torrance(base, scalar_column(1.0), scalar_column(roughness), n, n, n);
    const Tensor plastic = shading::cook_torrance(base, scalar_column(0.0), scalar_column(roughness), n, n, n);
    for (std::int64_t c = 0; c < 3; ++c) {
      CHECK(metal.at({0, c}) == Approx(base.at({c}) / (4 * kPi * a2)).epsilon(1e-12));
      CHECK(plastic.at({0, c}) == Approx(0.96 * base.at({c}) / kPi + 0.04 / (4 * kPi * a2)).epsilon(1e-12));
    }
  }
}

TEST_CASE("cook_torrance: roughness below 0.03 shades as 0.03, above 1 as 1, and a light below the horizon gives 0",
          "[ops][shading][brdf]") {
  const Scene s = lit_scene(6, 0.2, 0.95, 40);
  const Tensor base = Tensor::uniform({6, 3}, 0, 1, 41, DType::Float64), metallic = scalar_column(0.3);
  auto shade = [&](double r) { return shading::cook_torrance(base, metallic, scalar_column(r), s.normal, s.light, s.view); };
  CHECK(gr::testing::same_bits(shade(0.001).detach(), shade(0.03).detach()));
  CHECK(gr::testing::same_bits(shade(3.0).detach(), shade(1.0).detach()));
  const Tensor below = at_angle(s.normal.detach(), s.light.detach(), -0.2);
  for (double c : shading::cook_torrance(base, metallic, scalar_column(0.5), s.normal, below, s.view).to_vector())
    CHECK(c == 0.0);
}

TEST_CASE("cook_torrance: a view at or below the horizon is shaded with n.v = 1e-4, term by term as the spec "
          "composes it",
          "[ops][shading][brdf]") {
  const Tensor n = normalize(vec3(0.1, 0.2, 1)), l = at_angle(n, vec3(1, 0, 0), 0.6);
  const Tensor base = vec3(0.7, 0.4, 0.1), metallic = scalar_column(0.25);
  const double alpha = 0.5 * 0.5;
  for (double cos_v : {0.0, -0.3}) {
    const Tensor v = at_angle(n, vec3(-1, 0.5, 0), cos_v), h = normalize(l + v);
    const Tensor f0 = 0.04 * (1.0 - metallic) + base * metallic;
    const Tensor f = shading::fresnel_schlick(maximum(dot(v, h), 0.0), f0);
    const Tensor specular = f * shading::ggx_distribution(dot(n, h), vec({alpha})) *
                            shading::smith_ggx_correlated(vec({1e-4}), dot(n, l), vec({alpha}));
    const Tensor expected = ((1.0 - f) * (1.0 - metallic) * base / kPi + specular) * dot(n, l);
    const Tensor got = shading::cook_torrance(base, metallic, scalar_column(0.5), n, l, v);
    for (std::int64_t c = 0; c < 3; ++c) CHECK(got.at({0, c}) == Approx(expected.at({0, c})).epsilon(1e-14));
  }
}

TEST_CASE("cook_torrance: gradients of every input match finite differences on random pixels",
          "[ops][shading][brdf][gradcheck]") {
  const Scene s = lit_scene(12, 0.2, 0.95, 50);
  const Tensor base = random_input({12, 3}, 0, 1, 51);
  const Tensor metallic = random_input({12, 1}, 0, 1, 52), roughness = random_input({12, 1}, 0.1, 0.9, 53);
  require_gradcheck("cook_torrance", cook_torrance_of, {base, metallic, roughness, s.normal, s.light, s.view});
  // One material, one light [3] and one view [3] for all pixels.
  require_gradcheck("cook_torrance broadcast", cook_torrance_of,
                    {leaf(vec3(0.8, 0.5, 0.2)), leaf(Tensor::scalar(0.4, DType::Float64)), leaf(scalar_column(0.45)),
                     leaf(unit_directions(10, 54)), leaf(normalize(vec3(0.1, 0.8, 0.5))), leaf(normalize(vec3(0.2, 0.3, 0.9)))},
                    with_eps(1e-6));
}

TEST_CASE("cook_torrance: gradients match finite differences at metallic 0 and 1, grazing light, n.v at the "
          "1e-4 clamp and roughness near 0.03 and 1",
          "[ops][shading][brdf][gradcheck]") {
  const Tensor n = normalize(vec3(0.1, -0.2, 1.0));
  const Tensor base = vec3(0.9, 0.5, 0.2);
  const Tensor l = at_angle(n, vec3(1, 0, 0), 0.7), v = at_angle(n, vec3(-1, 0.3, 0), 0.8);
  struct Case {
    const char* name;
    double metallic, roughness;
    Tensor light, view;
    double eps;
  };
  const Case cases[] = {
      {"metallic 0", 0.0, 0.5, l, v, 1e-5},
      {"metallic 1", 1.0, 0.5, l, v, 1e-5},
      {"grazing light n.l = 1e-3", 0.3, 0.5, at_angle(n, vec3(1, 0, 0), 1e-3), v, 1e-6},
      {"light below, n.l = -1e-3", 0.3, 0.5, at_angle(n, vec3(1, 0, 0), -1e-3), v, 1e-6},
      {"n.v just above 1e-4", 0.3, 0.5, l, at_angle(n, vec3(-1, 0.3, 0), 1e-4 + 1e-5), 1e-7},
      {"n.v just below 1e-4", 0.3, 0.5, l, at_angle(n, vec3(-1, 0.3, 0), 1e-4 - 1e-5), 1e-7},
      {"view below the horizon", 0.3, 0.5, l, at_angle(n, vec3(-1, 0.3, 0), -0.3), 1e-6},
      {"roughness just above 0.03", 0.3, 0.03 + 1e-4, l, v, 1e-6},
      {"roughness below 0.03", 0.3, 0.02, l, v, 1e-6},
      {"roughness just below 1", 0.3, 1 - 1e-4, l, v, 1e-6},
      {"roughness above 1", 0.3, 1.2, l, v, 1e-6},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    require_gradcheck(std::string("cook_torrance ") + c.name, cook_torrance_of,
                      {leaf(base), leaf(scalar_column(c.metallic)), leaf(scalar_column(c.roughness)), leaf(n),
                       leaf(c.light), leaf(c.view)},
                      with_eps(c.eps));
  }
}

TEST_CASE("cook_torrance: gradients match finite differences on the sharpest highlight (roughness 0.03, near mirror)",
          "[ops][shading][brdf][gradcheck]") {
  // alpha = 9e-4: the lobe is about alpha^2 wide in n.h, so the normal (which
  // moves n.h to first order) needs a step of 1e-8; near the lobe's top n.h is
  // stationary in l and v, whose small gradients need a step of 1e-5 to rise
  // above the rounding of d = n.h^2 (alpha^2 - 1) + 1 (a cancellation);
  // roughness may not step across the clamp (1e-6).
  const Tensor n = normalize(vec3(0.1, -0.2, 1.0));
  const Tensor l = at_angle(n, vec3(1, 0, 0), 0.8), v = at_angle(n, vec3(-1, 0.003, 0), 0.8);
  REQUIRE(1 - dot(n, normalize(l + v)).item() < 1e-6);  // h within 1.5e-3 rad of n
  const struct {
    std::vector<int> checked;
    double eps;
  } groups[] = {{{0, 1, 2}, 1e-6}, {{3}, 1e-8}, {{4, 5}, 1e-5}};
  for (const auto& group : groups) {
    std::vector<Tensor> in = {vec3(0.9, 0.5, 0.2), scalar_column(0.8), scalar_column(0.03 + 1e-5), n, l, v};
    for (int k : group.checked) in[static_cast<std::size_t>(k)] = leaf(in[static_cast<std::size_t>(k)]);
    require_gradcheck("cook_torrance sharp highlight", cook_torrance_of, in, with_eps(group.eps));
  }
}

TEST_CASE("cook_torrance: at roughness exactly 0.03 and 1 the gradient is the one from inside the clamp",
          "[ops][shading][brdf]") {
  const Scene s = lit_scene(1, 0.5, 0.6, 60);
  auto roughness_grad = [&](double r) {
    Tensor rough = leaf(scalar_column(r));
    backward(sum(shading::cook_torrance(vec3(0.7, 0.4, 0.2), scalar_column(0.5), rough, s.normal.detach(),
                                        s.light.detach(), s.view.detach())));
    return rough.grad().item();
  };
  CHECK(roughness_grad(0.03) == Approx(roughness_grad(0.03 + 1e-9)).epsilon(1e-5));
  CHECK(roughness_grad(1.0) == Approx(roughness_grad(1.0 - 1e-9)).epsilon(1e-5));
  CHECK(roughness_grad(1.0) != 0.0);
  CHECK(roughness_grad(0.01) == 0.0);
  CHECK(roughness_grad(1.5) == 0.0);
}

TEST_CASE("cook_torrance: float32 inputs give float32 values close to float64's", "[ops][shading][brdf]") {
  const Scene s = lit_scene(8, 0.1, 1.0, 70);
  const Tensor base = Tensor::uniform({8, 3}, 0, 1, 71, DType::Float64);
  const Tensor m = Tensor::uniform({8, 1}, 0, 1, 72, DType::Float64), r = Tensor::uniform({8, 1}, 0.1, 1, 73, DType::Float64);
  const Tensor f64 = shading::cook_torrance(base, m, r, s.normal, s.light, s.view);
  auto f = [](const Tensor& t) { return cast(t.detach(), DType::Float32); };
  const Tensor f32 = shading::cook_torrance(f(base), f(m), f(r), f(s.normal), f(s.light), f(s.view));
  CHECK(f32.dtype() == DType::Float32);
  CHECK(gr::testing::max_relative_difference(f32.to_vector(), f64.to_vector()) < 1e-5);
}

// --- errors ------------------------------------------------------------------

TEST_CASE("brdf: wrong shapes, dtypes and non-broadcasting arguments are rejected naming the argument",
          "[ops][shading][brdf][errors]") {
  const Tensor v3 = Tensor::zeros({4, 3}, DType::Float64), s1 = Tensor::zeros({4, 1}, DType::Float64);
  CHECK_THROWS_AS(shading::lambert(v3, Tensor::zeros({4, 2}, DType::Float64), v3), ShapeError);
  CHECK_THROWS_WITH(shading::lambert(v3, Tensor::zeros({4, 2}, DType::Float64), v3),
                    Catch::Contains("shading::lambert") && Catch::Contains("'normal'") && Catch::Contains("[..., 3]"));
  CHECK_THROWS_AS(shading::lambert(v3, v3, Tensor::zeros({4, 3})), DTypeError);
  CHECK_THROWS_WITH(shading::lambert(v3, v3, Tensor::zeros({4, 3})), Catch::Contains("'light_dir'"));
  CHECK_THROWS_WITH(shading::lambert(v3, v3, Tensor::zeros({4, 3}, DType::Int32)), Catch::Contains("'light_dir'"));
  CHECK_THROWS_AS(shading::lambert(v3, Tensor::zeros({5, 3}, DType::Float64), v3), ShapeError);
  CHECK_THROWS_WITH(shading::lambert(v3, Tensor::zeros({5, 3}, DType::Float64), v3),
                    Catch::Contains("'normal'") && Catch::Contains("broadcast"));
  CHECK_THROWS_WITH(shading::lambert(Tensor(), v3, v3), Catch::Contains("'albedo'"));
  CHECK_THROWS_AS(shading::blinn_phong(v3, v3, v3, v3, v3, v3), ShapeError);
  CHECK_THROWS_WITH(shading::blinn_phong(v3, v3, v3, v3, v3, v3), Catch::Contains("'shininess'"));
  CHECK_THROWS_WITH(shading::blinn_phong(v3, v3, s1, v3, v3, Tensor::zeros({3, 4}, DType::Float64)),
                    Catch::Contains("'view_dir'"));
  CHECK_THROWS_WITH(shading::cook_torrance(v3, v3, s1, v3, v3, v3), Catch::Contains("'metallic'"));
  CHECK_THROWS_WITH(shading::cook_torrance(v3, s1, Tensor::zeros({2, 1}, DType::Float64), v3, v3, v3),
                    Catch::Contains("'roughness'") && Catch::Contains("broadcast"));
  CHECK_THROWS_WITH(shading::cook_torrance(v3, s1, s1, v3, v3, Tensor::zeros({4, 3})),
                    Catch::Contains("shading::cook_torrance") && Catch::Contains("'view_dir'") &&
                        Catch::Contains("dtype"));
  CHECK_THROWS_WITH(shading::ggx_distribution(s1, Tensor::zeros({4, 1})), Catch::Contains("'alpha'"));
  CHECK_THROWS_WITH(shading::smith_ggx_correlated(s1, Tensor::zeros({3, 1}, DType::Float64), s1),
                    Catch::Contains("'n_dot_l'"));
  CHECK_THROWS_WITH(shading::fresnel_schlick(Tensor::zeros({4, 1}, DType::Int32), v3), Catch::Contains("'cos_theta'"));
}
