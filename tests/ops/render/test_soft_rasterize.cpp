// The soft rasterizer: values by hand (inside, at a known distance outside,
// beyond the cut-off, depth order), the max_faces bound, float64 gradient
// checks of every input on random and hard scenes, thread-count determinism
// and argument checks.
#include <catch2/catch.hpp>

#include <cmath>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

constexpr int W = 20, H = 16;

Tensor f64(std::vector<double> v, Shape s) { return Tensor::from_values(v, s, DType::Float64); }
Tensor tris(std::vector<std::int32_t> v) {
  return Tensor::from_vector<std::int32_t>(v, {static_cast<std::int64_t>(v.size() / 3), 3});
}

// One triangle at depth z (w = 1) covering the left part of the image.
Tensor left_triangle(double z) { return f64({-1.5, -1.5, z, 1, 0.0, -1.5, z, 1, -1.5, 1.5, z, 1}, {3, 4}); }

SoftRasterizeOptions options() {
  SoftRasterizeOptions o;
  o.width = W;
  o.height = H;
  return o;
}

Tensor scalar(double v) { return Tensor::scalar(v, DType::Float64); }

}  // namespace

TEST_CASE("soft rasterize: far inside a triangle the colour is the attribute, beyond the cut-off the background",
          "[soft_rasterize]") {
  const Tensor attr = f64({0.2, 0.2, 0.2}, {3, 1});
  const Tensor out = soft_rasterize(left_triangle(0.0), tris({0, 1, 2}), attr, scalar(0.5), scalar(0.01), options(),
                                    f64({0.9}, {1}));
  // Pixel (row 8, col 2) is far inside (D = 1), zs = 0.5 against the background's 0: w = 1 / (1 + e^-50).
  CHECK(out.at({8, 2, 0}) == Approx(0.2).margin(1e-12));
  // Screen vertices (-5, 20), (10, 20), (-5, -4): pixel (row 1, column 19) is 17.9 pixels from the hypotenuse.
  CHECK(out.at({1, 19, 0}) == 0.9);
}

TEST_CASE("soft rasterize: at a known distance outside an edge the weight is the sigmoid times the depth softmax",
          "[soft_rasterize]") {
  // Screen vertices (-5, 20), (10, 20), (10, -4): the edge x = 10 is vertical; pixel (row 14, column 11)
  // has its centre 1.5 pixels to its right.
  const double sigma = 2.0, gamma = 0.5, z = 0.2;
  const Tensor clip = f64({-1.5, -1.5, z, 1, 0.0, -1.5, z, 1, 0.0, 1.5, z, 1}, {3, 4});
  const Tensor out = soft_rasterize(clip, tris({0, 1, 2}), f64({1, 1, 1}, {3, 1}), scalar(sigma),
                                    scalar(gamma), options(), f64({0}, {1}));
  const double D = 1.0 / (1.0 + std::exp(1.5 * 1.5 / sigma));
  const double e = D * std::exp((1.0 - z) / 2.0 / gamma);
  CHECK(out.at({14, 11, 0}) == Approx(e / (e + 1.0)).epsilon(1e-12));
}

TEST_CASE("soft rasterize: with a small gamma the nearer of two overlapping triangles wins", "[soft_rasterize]") {
  Tensor clip = concat({left_triangle(0.5), left_triangle(-0.5)}, 0);
  const Tensor attr = f64({1, 1, 1, 2, 2, 2}, {6, 1});
  const Tensor out = soft_rasterize(clip, tris({0, 1, 2, 3, 4, 5}), attr, scalar(0.5), scalar(0.01), options());
  CHECK(out.at({8, 2, 0}) == Approx(2.0).margin(1e-12));  // z = -0.5 is nearer
}

TEST_CASE("soft rasterize: only the max_faces nearest triangles of a pixel are blended", "[soft_rasterize]") {
  std::vector<Tensor> layers;
  std::vector<double> a;
  for (int k = 0; k < 5; ++k) {
    layers.push_back(left_triangle(-0.4 + 0.2 * k));
    for (int i = 0; i < 3; ++i) a.push_back(k + 1.0);
  }
  SoftRasterizeOptions o = options();
  o.max_faces = 2;
  const Tensor all = soft_rasterize(concat(layers, 0), tris({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14}),
                                    f64(a, {15, 1}), scalar(1.0), scalar(0.3), o);
  const Tensor nearest = soft_rasterize(concat({layers[0], layers[1]}, 0), tris({0, 1, 2, 3, 4, 5}),
                                        f64({1, 1, 1, 2, 2, 2}, {6, 1}), scalar(1.0), scalar(0.3), o);
  CHECK(all.to_vector() == nearest.to_vector());
}

TEST_CASE("soft rasterize: gradients of clip, attributes, background, sigma and gamma match finite differences",
          "[soft_rasterize][gradcheck]") {
  SECTION("random triangles in perspective") {
    Tensor clip = f64({-0.7, -0.6, 0.1, 1.0, 0.8, -0.5, 0.3, 1.5, 0.1, 0.7, -0.2, 0.8,   //
                       0.2, -0.9, 0.4, 1.1, 0.9, 0.6, 0.0, 1.3, -0.6, 0.5, 0.2, 0.9},
                      {6, 4});
    clip.set_requires_grad();
    const Tensor attr = random_input({6, 2}, 0, 1, 3), bg = random_input({2}, 0, 1, 4);
    Tensor sigma = scalar(3.0), gamma = scalar(0.2);
    sigma.set_requires_grad();
    gamma.set_requires_grad();
    const Tensor t = tris({0, 1, 2, 3, 4, 5});
    require_gradcheck("soft_rasterize random",
                      [&](const Inputs& in) { return soft_rasterize(in[0], t, in[1], in[3], in[4], options(), in[2]); },
                      {clip, attr, bg, sigma, gamma});
  }
  SECTION("a sliver and two coplanar overlapping triangles") {
    Tensor clip = f64({-0.9, -0.1, 0.0, 1.0, 0.9, 0.0, 0.0, 1.0, -0.9, 0.02, 0.0, 1.0,  //
                       -0.5, -0.5, 0.3, 1.0, 0.5, -0.5, 0.3, 1.0, 0.0, 0.6, 0.3, 1.0,  //
                       -0.4, -0.6, 0.3, 1.0, 0.6, -0.4, 0.3, 1.0, -0.1, 0.5, 0.3, 1.0},
                      {9, 4});
    clip.set_requires_grad();
    const Tensor attr = random_input({9, 3}, 0, 1, 5);
    Tensor sigma = scalar(1.5), gamma = scalar(0.1);
    sigma.set_requires_grad();
    gamma.set_requires_grad();
    const Tensor t = tris({0, 1, 2, 3, 4, 5, 6, 7, 8});
    require_gradcheck("soft_rasterize sliver+coplanar",
                      [&](const Inputs& in) { return soft_rasterize(in[0], t, in[1], in[2], in[3], options()); },
                      {clip, attr, sigma, gamma});
  }
}

TEST_CASE("soft rasterize: images and gradients are bit-identical for 1, 2 and 8 threads", "[soft_rasterize][parallel]") {
  const Tensor t = tris({0, 1, 2, 1, 3, 2});
  std::vector<std::vector<double>> runs;
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    Tensor clip = f64({-0.7, -0.6, 0.1, 1.0, 0.8, -0.5, 0.3, 1.5, 0.1, 0.7, -0.2, 0.8, 0.9, 0.8, 0.5, 1.2}, {4, 4});
    clip.set_requires_grad();
    Tensor attr = random_input({4, 3}, 0, 1, 7);
    SoftRasterizeOptions o;
    o.width = 96;
    o.height = 80;
    Tensor out = soft_rasterize(clip, t, attr, scalar(2.0), scalar(0.1), o);
    backward(sum(mul(out, out)));
    std::vector<double> r = out.to_vector();
    for (const Tensor& g : {clip.grad(), attr.grad()})
      for (double v : g.to_vector()) r.push_back(v);
    runs.push_back(r);
  }
  set_num_threads(0);
  CHECK(runs[0] == runs[1]);
  CHECK(runs[0] == runs[2]);
}

TEST_CASE("soft rasterize: bad arguments are errors naming them", "[soft_rasterize]") {
  const Tensor clip = left_triangle(0.0), t = tris({0, 1, 2}), attr = f64({1, 1, 1}, {3, 1});
  CHECK_THROWS_WITH(soft_rasterize(clip, t, attr, scalar(0.0), scalar(0.1), options()),
                    Catch::Contains("'sigma' must be finite and > 0"));
  CHECK_THROWS_WITH(soft_rasterize(clip, t, attr, scalar(1.0), scalar(-1.0), options()),
                    Catch::Contains("'gamma' must be finite and > 0"));
  CHECK_THROWS_WITH(soft_rasterize(clip, t, f64({1, 1}, {2, 1}), scalar(1.0), scalar(0.1), options()),
                    Catch::Contains("'attributes' must be [N, C] with N = 3"));
  CHECK_THROWS_WITH(soft_rasterize(clip, t, attr, scalar(1.0), scalar(0.1), options(), f64({1, 2}, {2})),
                    Catch::Contains("background"));
  SoftRasterizeOptions o = options();
  o.max_faces = 0;
  CHECK_THROWS_WITH(soft_rasterize(clip, t, attr, scalar(1.0), scalar(0.1), o), Catch::Contains("'max_faces'"));
  Tensor bad = clip.detach();
  bad = f64({-1.5, -1.5, 0, 1, NAN, -1.5, 0, 1, -1.5, 1.5, 0, 1}, {3, 4});
  CHECK_THROWS_WITH(soft_rasterize(bad, t, attr, scalar(1.0), scalar(0.1), options()), Catch::Contains("clip[4]"));
  CHECK_THROWS_AS(soft_rasterize(clip, tris({0, 1, 3}), attr, scalar(1.0), scalar(0.1), options()), IndexError);
}

TEST_CASE("soft rasterize: a gamma so small that 1 / gamma or eps / gamma overflows is refused naming it",
          "[soft_rasterize]") {
  // An audit's finding: gamma = 1e-320 or eps / gamma = Inf passed as "finite
  // and > 0", and the depth softmax then gave NaN everywhere (Inf - Inf).
  const Tensor clip = left_triangle(0.0), t = tris({0, 1, 2}), attr = f64({1, 1, 1}, {3, 1});
  CHECK_THROWS_WITH(soft_rasterize(clip, t, attr, scalar(1.0), scalar(1e-320), options()),
                    Catch::Contains("'gamma' = 9.99988867") && Catch::Contains("is too small"));
  SoftRasterizeOptions o = options();
  o.eps = 1e300;
  CHECK_THROWS_WITH(soft_rasterize(clip, t, attr, scalar(1.0), scalar(1e-10), o), Catch::Contains("eps / gamma"));
}

TEST_CASE("soft rasterize: screen positions near the float64 range and extreme sigma and gamma stay finite",
          "[soft_rasterize]") {
  // An audit's findings: a vertex with x / w or z / w near 1e308 made the edge
  // functions overflow (NaN barycentrics, spread by the softmax over whole
  // pixels), and the gradients of sigma and gamma were NaN for sigma = 1e-320
  // (0 * Inf where the sigmoid is flat) and gamma = 1e-300 (gamma^2 = 0).
  const Tensor t = tris({0, 1, 2, 3, 4, 5, 6, 7, 8});
  Tensor clip = f64({0, -1.3e-129, -1.8e-44, 1,  // x / w = 3e170, z / w = Inf
                           1.34e132, 3.6e27, 1.7976931348623157e308, 4.77e-39,
                           -7.4e293, 2.2e-24, -4.2e-235, 1.04e-219,
                           3.4e-203, 1, 3.3e190, 4.4e254,  // finite screen positions up to 1e292
                           -2.8e177, -1.7976931348623157e308, -1, 4.2e152,
                           1.78e291, -4.9e-324, -0.0, 1,
                           -0.5, -0.5, 0.2, 1, 0.5, -0.5, 0.2, 1, 0, 0.5, 0.2, 1},  // an ordinary triangle
                          {9, 4})
                          .set_requires_grad();
  Tensor attr = random_input({9, 2}, -1, 1, 3).set_requires_grad();
  for (const auto& [s, g] : std::vector<std::pair<double, double>>{{1e-4, 1e4}, {1e30, 1e-4}, {1e-320, 1.0},
                                                                    {1.0, 1e-300}, {1e308, 1.0}}) {
    INFO("sigma " << s << ", gamma " << g);
    Tensor sigma = scalar(s).set_requires_grad(), gamma = scalar(g).set_requires_grad();
    const Tensor out = soft_rasterize(clip, t, attr, sigma, gamma, options());
    backward(sum(out));
    for (const Tensor& x : {out, clip.grad(), attr.grad(), sigma.grad(), gamma.grad()})
      for (double v : x.to_vector()) REQUIRE(std::isfinite(v));
    clip.zero_grad();
    attr.zero_grad();
  }
}
