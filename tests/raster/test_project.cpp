// Tests of the projection kernels: perspective divide and viewport, forward
// values by hand and adjoints against central finite differences.
#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/project.h"
#include "raster/kernel_checks.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

}  // namespace

TEST_CASE("wdivide: divides x, y, z by w", "[raster][project]") {
  const std::vector<double> clip = {2, -4, 1, 2, 3, 6, -9, -3};
  std::vector<double> ndc(6);
  wdivide_forward(clip.data(), 2, ndc.data());
  CHECK(ndc == std::vector<double>{1, -2, 0.5, -1, -2, 3});
}

TEST_CASE("wdivide: w exactly 0 throws a ValueError naming the vertex", "[raster][project]") {
  const std::vector<double> clip = {1, 1, 1, 1, 1, 1, 1, 0};
  std::vector<double> ndc(6);
  CHECK_THROWS_AS(wdivide_forward(clip.data(), 2, ndc.data()), ValueError);
  CHECK_THROWS_WITH(wdivide_forward(clip.data(), 2, ndc.data()), Catch::Contains("vertex 1"));
  // A zero gradient through w = 0 is fine; a non-zero one is not.
  std::vector<double> g(6, 0.0), gc(8, 0.0);
  CHECK_NOTHROW(wdivide_backward(clip.data(), 2, g.data(), gc.data()));
  g[4] = 1;
  CHECK_THROWS_AS(wdivide_backward(clip.data(), 2, g.data(), gc.data()), ValueError);
}

TEST_CASE("wdivide: gradient matches finite differences", "[raster][project]") {
  const int n = 5;
  std::vector<double> clip = random_vector(4 * n, -2, 2, 1);
  for (int i = 0; i < n; ++i) clip[4 * i + 3] = 0.5 + std::abs(clip[4 * i + 3]);
  clip[3] = -1.3;  // negative w is allowed (no clipping here)
  const std::vector<double> wts = random_vector(3 * n, -1, 1, 2);
  auto loss = [&](const std::vector<double>& c) {
    std::vector<double> ndc(3 * n);
    wdivide_forward(c.data(), n, ndc.data());
    double l = 0;
    for (int i = 0; i < 3 * n; ++i) l += wts[i] * ndc[i];
    return l;
  };
  std::vector<double> grad(4 * n, 0.25);  // accumulates onto existing values
  wdivide_backward(clip.data(), n, wts.data(), grad.data());
  for (double& g : grad) g -= 0.25;
  const double err = fd_error(loss, clip, grad);
  INFO("relative error " << err);
  CHECK(err < 1e-8);
}

TEST_CASE("viewport: maps NDC corners to image corners with row 0 at the top", "[raster][project]") {
  const std::vector<double> ndc = {-1, 1, 0, 1, -1, 0.5};
  std::vector<double> s(4);
  viewport_forward(ndc.data(), 2, 640, 480, s.data());
  CHECK(s == std::vector<double>{0, 0, 640, 480});
}

TEST_CASE("viewport: gradient matches finite differences", "[raster][project]") {
  const int n = 4, W = 37, H = 23;
  const std::vector<double> ndc = random_vector(3 * n, -1, 1, 3);
  const std::vector<double> wts = random_vector(2 * n, -1, 1, 4);
  auto loss = [&](const std::vector<double>& x) {
    std::vector<double> s(2 * n);
    viewport_forward(x.data(), n, W, H, s.data());
    double l = 0;
    for (int i = 0; i < 2 * n; ++i) l += wts[i] * s[i];
    return l;
  };
  std::vector<double> grad(3 * n, 0.0);
  viewport_backward(n, W, H, wts.data(), grad.data());
  const double err = fd_error(loss, ndc, grad);
  INFO("relative error " << err);
  CHECK(err < 1e-8);
}

TEST_CASE("screen_to_clip_backward equals viewport then wdivide adjoints and stays finite for tiny w",
          "[raster][project]") {
  const int W = 64, H = 48;
  const std::vector<double> clip = {0.3, -0.2, 0.5, 1.5, -1.1, 0.7, 0.2, 2.0, 0.1, 0.1, -0.4, 0.8};
  const std::vector<double> g_screen = {0.7, -1.3, 0.4, 2.1, -0.6, 0.0, 0.0, 0.0, 0.9};  // x, y, z_ndc per vertex
  std::vector<double> fused(12, 0.5), chained(12, 0.5);
  screen_to_clip_backward(clip.data(), 3, W, H, g_screen.data(), 3, fused.data());
  std::vector<double> g_xy(6), g_ndc(9);
  for (int i = 0; i < 3; ++i) {
    g_xy[2 * i] = g_screen[3 * i];
    g_xy[2 * i + 1] = g_screen[3 * i + 1];
    g_ndc[3 * i + 2] = g_screen[3 * i + 2];
  }
  viewport_backward(3, W, H, g_xy.data(), g_ndc.data());
  wdivide_backward(clip.data(), 3, g_ndc.data(), chained.data());
  for (int i = 0; i < 12; ++i) CHECK(fused[i] == Approx(chained[i]).epsilon(1e-14));

  // float32, w = 1e-39: 1/w is beyond FLT_MAX; clamped, not Inf.
  const float tiny = 1e-39f;
  const std::vector<float> clip32 = {0.5f * tiny, 0.5f * tiny, 0, tiny};
  const std::vector<double> g2 = {1.0, 1.0};
  std::vector<float> out(4, 0.0f);
  screen_to_clip_backward(clip32.data(), 1, W, H, g2.data(), 2, out.data());
  for (float v : out) CHECK(std::isfinite(v));
  CHECK(out[0] == std::numeric_limits<float>::max());
  CHECK(out[1] == -std::numeric_limits<float>::max());
}
