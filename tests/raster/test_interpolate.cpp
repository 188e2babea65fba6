// Tests of attribute interpolation: hand values, perspective correctness
// against an analytic ray-plane intersection, background handling, adjoints
// against central finite differences, determinism and bad input.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/interpolate.h"
#include "raster/rasterize.h"
#include "raster/kernel_checks.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

// Image-form kernel params in the order of the kernels' former argument list.
InterpolateParams<double> image_params(const double* attr, std::int64_t N, std::int64_t C, const double* clip,
                                       const std::int32_t* tris, std::int64_t M, const std::int32_t* id,
                                       const double* uv, int W, int H, bool perspective,
                                       const double* background = nullptr) {
  InterpolateParams<double> p;
  p.attr = attr;
  p.num_vertices = N;
  p.channels = C;
  p.clip = clip;
  p.tris = tris;
  p.num_tris = M;
  p.tri_id = id;
  p.uv = uv;
  p.width = W;
  p.height = H;
  p.perspective = perspective;
  p.background = background;
  return p;
}

// A small synthetic G-buffer over 3 triangles and 6 vertices, all in front of
// the near plane (|z| < w), so no triangle takes the clipped form.
struct Scene {
  int W = 5, H = 4, N = 6, M = 3, C = 3;
  std::vector<double> attr, clip, uv;
  std::vector<std::int32_t> tris = {0, 1, 2, 2, 1, 3, 4, 5, 0}, id;
  explicit Scene(unsigned seed) {
    attr = random_vector(N * C, -2, 2, seed);
    clip = random_vector(4 * N, -1, 1, seed + 1);
    for (int i = 0; i < N; ++i) {
      clip[4 * i + 3] = 0.5 + 1.5 * std::abs(clip[4 * i + 3]);
      clip[4 * i + 2] *= 0.45;
    }
    uv = random_vector(2 * W * H, 0.05, 0.45, seed + 2);
    std::mt19937 rng(seed + 3);
    for (int p = 0; p < W * H; ++p) id.push_back(static_cast<std::int32_t>(rng() % (M + 1)));
    id[0] = 0;
    id[1] = 1;
  }
  std::vector<double> forward(const std::vector<double>& a, const std::vector<double>& c,
                              const std::vector<double>& u, bool perspective,
                              const double* background = nullptr) const {
    std::vector<double> out(W * H * C);
    interpolate_forward(
        image_params(a.data(), N, C, c.data(), tris.data(), M, id.data(), u.data(), W, H, perspective, background),
        out.data());
    return out;
  }
};

}  // namespace

TEST_CASE("interpolate: a pixel gets the linear or 1/w-weighted mix of its vertices",
          "[raster][interpolate]") {
  const std::vector<double> attr = {1, 10, 2, 20, 4, 40};
  const std::vector<double> clip = {0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 4};
  const std::vector<std::int32_t> tris = {0, 1, 2}, id = {1, 0};
  const std::vector<double> uv = {0.25, 0.5, 0.3, 0.3};
  const double bg[2] = {-7, 8};
  std::vector<double> out(4);
  interpolate_forward(
      image_params(attr.data(), 3, 2, clip.data(), tris.data(), 1, id.data(), uv.data(), 2, 1, false, bg), out.data());
  CHECK(out[0] == Approx(0.25 * 1 + 0.25 * 2 + 0.5 * 4));
  CHECK(out[1] == Approx(10 * out[0]));
  CHECK(out[2] == -7);
  CHECK(out[3] == 8);
  interpolate_forward(image_params(attr.data(), 3, 2, clip.data(), tris.data(), 1, id.data(), uv.data(), 2, 1, true),
                      out.data());
  const double q0 = 0.25 / 1, q1 = 0.25 / 2, q2 = 0.5 / 4;
  CHECK(out[0] == Approx((q0 * 1 + q1 * 2 + q2 * 4) / (q0 + q1 + q2)));
  CHECK(out[2] == 0);
  CHECK(out[3] == 0);
}

TEST_CASE("interpolate: perspective mode matches the ray-plane intersection at a grazing angle",
          "[raster][interpolate][perspective]") {
  // A floor quad y = -1 from z = -1.5 to z = -30 in view space; attribute = (x, z).
  const double t = 1.0 / std::tan(0.6), n = 0.1, f = 100.0;
  const double vx[4][3] = {{-4, -1, -1.5}, {4, -1, -1.5}, {4, -1, -30}, {-4, -1, -30}};
  std::vector<double> clip, attr;
  for (const auto& p : vx) {
    clip.insert(clip.end(), {t * p[0], t * p[1], (f + n) / (n - f) * p[2] + 2 * f * n / (n - f), -p[2]});
    attr.insert(attr.end(), {p[0], p[2]});
  }
  const std::vector<std::int32_t> tris = {0, 1, 2, 0, 2, 3};
  const int W = 64, H = 64;
  std::vector<std::int32_t> id(W * H);
  std::vector<double> uv(2 * W * H), depth(W * H), persp(2 * W * H), lin(2 * W * H);
  rasterize_forward(RasterParams<double>{clip.data(), 4, tris.data(), 2, RasterSettings{W, H, Cull::None}}, id.data(),
                    uv.data(), depth.data());
  interpolate_forward(image_params(attr.data(), 4, 2, clip.data(), tris.data(), 2, id.data(), uv.data(), W, H, true),
                      persp.data());
  interpolate_forward(image_params(attr.data(), 4, 2, clip.data(), tris.data(), 2, id.data(), uv.data(), W, H, false),
                      lin.data());
  int covered = 0;
  double worst_persp = 0, worst_lin = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const int p = j * W + i;
      if (!id[p]) continue;
      ++covered;
      // Ray through the pixel centre hits y = -1 at z = t / ndc_y.
      const double ndc_x = (i + 0.5) / (0.5 * W) - 1, ndc_y = 1 - (j + 0.5) / (0.5 * H);
      const double z = t / ndc_y, x = ndc_x / t * (-z);
      worst_persp = std::max({worst_persp, std::abs(persp[2 * p] - x), std::abs(persp[2 * p + 1] - z) / -z});
      worst_lin = std::max(worst_lin, std::abs(lin[2 * p + 1] - z) / -z);
    }
  INFO("worst perspective error " << worst_persp << ", linear " << worst_lin);
  CHECK(covered > 500);
  CHECK(worst_persp < 1e-9);
  CHECK(worst_lin > 0.1);
}

TEST_CASE("interpolate: gradients w.r.t. attributes, w and uv match finite differences",
          "[raster][interpolate][gradient]") {
  for (bool perspective : {true, false}) {
    INFO("perspective " << perspective);
    const Scene s(21);
    const std::vector<double> wts = random_vector(s.W * s.H * s.C, -1, 1, 99);
    auto loss = [&](const std::vector<double>& a, const std::vector<double>& c, const std::vector<double>& u) {
      const std::vector<double> out = s.forward(a, c, u, perspective);
      double l = 0;
      for (std::size_t i = 0; i < out.size(); ++i) l += wts[i] * out[i];
      return l;
    };
    std::vector<double> ga(s.attr.size(), 0.0), gc(s.clip.size(), 0.0), gu(s.uv.size(), 0.0);
    interpolate_backward(image_params(s.attr.data(), s.N, s.C, s.clip.data(), s.tris.data(), s.M, s.id.data(),
                                      s.uv.data(), s.W, s.H, perspective),
                         wts.data(), {ga.data(), gc.data(), gu.data()});
    const double ea = fd_error([&](const std::vector<double>& a) { return loss(a, s.clip, s.uv); }, s.attr, ga);
    const double ec = fd_error([&](const std::vector<double>& c) { return loss(s.attr, c, s.uv); }, s.clip, gc);
    const double eu = fd_error([&](const std::vector<double>& u) { return loss(s.attr, s.clip, u); }, s.uv, gu);
    INFO("relative errors attr " << ea << " clip " << ec << " uv " << eu);
    CHECK(ea < 1e-8);
    CHECK(ec < 1e-8);
    CHECK(eu < 1e-8);
    // Only w receives gradient, background pixels none.
    for (int i = 0; i < s.N; ++i)
      for (int k = 0; k < 3; ++k) CHECK(gc[4 * i + k] == 0);
    CHECK(gu[0] == 0);
    CHECK(gu[1] == 0);
    // Null outputs are skipped, and the others unchanged.
    std::vector<double> gu2(s.uv.size(), 0.0);
    interpolate_backward(image_params(s.attr.data(), s.N, s.C, s.clip.data(), s.tris.data(), s.M, s.id.data(),
                                      s.uv.data(), s.W, s.H, perspective),
                         wts.data(), {nullptr, nullptr, gu2.data()});
    CHECK(gu2 == gu);
  }
}

TEST_CASE("interpolate: background pixels get the background value and no gradient",
          "[raster][interpolate]") {
  const Scene s(5);
  const std::vector<double> bg = {1.5, -2.5, 3.5};
  const std::vector<double> out = s.forward(s.attr, s.clip, s.uv, true, bg.data());
  for (int p = 0; p < s.W * s.H; ++p)
    if (s.id[p] == 0)
      for (int c = 0; c < s.C; ++c) CHECK(out[p * s.C + c] == bg[c]);
  // A gradient only on background pixels reaches nothing.
  std::vector<double> g(out.size(), 0.0);
  for (int p = 0; p < s.W * s.H; ++p)
    if (s.id[p] == 0)
      for (int c = 0; c < s.C; ++c) g[p * s.C + c] = 1;
  std::vector<double> ga(s.attr.size(), 0.0), gc(s.clip.size(), 0.0), gu(s.uv.size(), 0.0);
  interpolate_backward(image_params(s.attr.data(), s.N, s.C, s.clip.data(), s.tris.data(), s.M, s.id.data(),
                                    s.uv.data(), s.W, s.H, true),
                       g.data(), {ga.data(), gc.data(), gu.data()});
  CHECK(std::all_of(ga.begin(), ga.end(), [](double x) { return x == 0; }));
  CHECK(std::all_of(gc.begin(), gc.end(), [](double x) { return x == 0; }));
  CHECK(std::all_of(gu.begin(), gu.end(), [](double x) { return x == 0; }));
}

TEST_CASE("interpolate: gradients are identical for 1 and 2 threads", "[raster][interpolate][determinism]") {
  const int W = 300, H = 200, N = 50, M = 40, C = 4;
  const std::vector<double> attr = random_vector(N * C, -1, 1, 1), g = random_vector(W * H * C, -1, 1, 2);
  std::vector<double> clip = random_vector(4 * N, 0.5, 2, 3);
  const std::vector<double> uv = random_vector(2 * W * H, 0.0, 0.5, 4);
  std::mt19937 rng(5);
  std::vector<std::int32_t> tris(3 * M), id(W * H);
  for (auto& i : tris) i = static_cast<std::int32_t>(rng() % N);
  for (auto& i : id) i = static_cast<std::int32_t>(rng() % (M + 1));
  auto run = [&](int threads) {
    gr::set_num_threads(threads);
    std::vector<double> out(W * H * C), ga(N * C, 0.0), gc(4 * N, 0.0), gu(2 * W * H, 0.0);
    interpolate_forward(image_params(attr.data(), N, C, clip.data(), tris.data(), M, id.data(), uv.data(), W, H, true),
                        out.data());
    interpolate_backward(image_params(attr.data(), N, C, clip.data(), tris.data(), M, id.data(), uv.data(), W, H, true),
                         g.data(), {ga.data(), gc.data(), gu.data()});
    out.insert(out.end(), ga.begin(), ga.end());
    out.insert(out.end(), gc.begin(), gc.end());
    out.insert(out.end(), gu.begin(), gu.end());
    return out;
  };
  const std::vector<double> one = run(1), two = run(2);
  gr::set_num_threads(0);
  CHECK(one == two);
}

TEST_CASE("interpolate: vertices at w <= 0 from near-plane clipping give finite values and gradients",
          "[raster][interpolate][near]") {
  // One vertex behind the camera: rasterize clips, interpolate must stay finite.
  std::vector<double> clip = {-0.6, -0.5, -0.8, 1.0, 0.7, -0.4, 1.3, 1.5, 0.1, 0.3, -0.8, -0.6};
  const std::vector<std::int32_t> tris = {0, 1, 2};
  const int W = 32, H = 32;
  std::vector<std::int32_t> id(W * H);
  std::vector<double> uv(2 * W * H), depth(W * H), out(W * H * 2);
  rasterize_forward(RasterParams<double>{clip.data(), 3, tris.data(), 1, RasterSettings{W, H, Cull::None}}, id.data(),
                    uv.data(), depth.data());
  const std::vector<double> attr = {1, 2, 3, 4, 5, 6};
  interpolate_forward(image_params(attr.data(), 3, 2, clip.data(), tris.data(), 1, id.data(), uv.data(), W, H, true),
                      out.data());
  CHECK(std::count_if(id.begin(), id.end(), [](int i) { return i != 0; }) > 10);
  const std::vector<double> g = random_vector(out.size(), -1, 1, 6);
  std::vector<double> ga(6, 0.0), gc(12, 0.0), gu(2 * W * H, 0.0);
  interpolate_backward(image_params(attr.data(), 3, 2, clip.data(), tris.data(), 1, id.data(), uv.data(), W, H, true),
                       g.data(), {ga.data(), gc.data(), gu.data()});
  for (const auto* v : {&out, &ga, &gc, &gu})
    CHECK(std::all_of(v->begin(), v->end(), [](double x) { return std::isfinite(x); }));
  // w exactly 0 at a vertex: still finite.
  clip[11] = 0.0;
  std::vector<double> uv0(2 * W * H, 0.2);
  interpolate_forward(image_params(attr.data(), 3, 2, clip.data(), tris.data(), 1, id.data(), uv0.data(), W, H, true),
                      out.data());
  interpolate_backward(image_params(attr.data(), 3, 2, clip.data(), tris.data(), 1, id.data(), uv0.data(), W, H, true),
                       g.data(), {ga.data(), gc.data(), gu.data()});
  for (const auto* v : {&out, &ga, &gc, &gu})
    CHECK(std::all_of(v->begin(), v->end(), [](double x) { return std::isfinite(x); }));
}

namespace {

// One triangle with a vertex behind the camera and, as vertex 2, a vertex at
// w = w2 (x = 0.3, y = -0.8, z = -0.6 - w2 so it is behind the near plane),
// rasterized on 32 x 32; attributes of 2 channels.
struct ClippedScene {
  int W = 32, H = 32;
  std::vector<double> clip, attr = {1, 2, 3, 4, 5, 6}, uv, depth;
  std::vector<std::int32_t> tris = {0, 1, 2}, id;
  explicit ClippedScene(double w2) {
    clip = {-0.6, -0.5, -0.8, 1.0, 0.7, -0.4, 1.3, 1.5, 0.3, -0.8, -0.6 - w2, w2};
    id.resize(W * H);
    uv.resize(2 * W * H);
    depth.resize(W * H);
    rasterize_forward(RasterParams<double>{clip.data(), 3, tris.data(), 1, RasterSettings{W, H, Cull::None}}, id.data(),
                      uv.data(), depth.data());
  }
  std::vector<double> forward(const std::vector<double>& c) const {
    std::vector<double> out(2 * W * H);
    interpolate_forward(image_params(attr.data(), 3, 2, c.data(), tris.data(), 1, id.data(), uv.data(), W, H, true),
                        out.data());
    return out;
  }
};

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

}  // namespace

TEST_CASE("interpolate: clipped triangles weight vertex k by F_k/D, equal to lambda_k/w_k of the stored uv",
          "[raster][interpolate][near]") {
  const ClippedScene s(-0.6);
  const std::vector<double> out = s.forward(s.clip);
  int covered = 0;
  double worst = 0;
  for (int p = 0; p < s.W * s.H; ++p) {
    if (!s.id[p]) continue;
    ++covered;
    // The screen-barycentric form: q_k = lambda_k / w_k with lambda from rasterize's uv.
    const double lambda[3] = {1 - s.uv[2 * p] - s.uv[2 * p + 1], s.uv[2 * p], s.uv[2 * p + 1]};
    double q[3], sum = 0;
    for (int k = 0; k < 3; ++k) sum += q[k] = lambda[k] / s.clip[4 * k + 3];
    for (int c = 0; c < 2; ++c) {
      double a = 0;
      for (int k = 0; k < 3; ++k) a += q[k] / sum * s.attr[2 * k + c];
      worst = std::max(worst, std::abs(out[2 * p + c] - a));
    }
  }
  INFO("worst difference " << worst);
  CHECK(covered > 10);
  CHECK(worst < 1e-10);
}

TEST_CASE("interpolate: a vertex at w = 0 keeps its perspective weight (continuous across w = 0)",
          "[raster][interpolate][near]") {
  // Same coverage for all three; only vertex 2's w differs.
  const ClippedScene plus(1e-15), zero(0.0), minus(-1e-15);
  REQUIRE(plus.id == zero.id);
  REQUIRE(minus.id == zero.id);
  const std::vector<double> a = plus.forward(plus.clip), b = zero.forward(zero.clip), c = minus.forward(minus.clip);
  CHECK(all_finite(b));
  CHECK(max_abs_diff(a, b) < 1e-12);
  CHECK(max_abs_diff(c, b) < 1e-12);
  // Vertex 2 keeps its weight: its attribute (5, 6) dominates the pixels seen
  // toward its direction (without it every pixel would mix vertices 0 and 1 only, in [1, 3]).
  double closest = 1e9;
  for (int p = 0; p < zero.W * zero.H; ++p)
    if (zero.id[p]) closest = std::min(closest, std::abs(b[2 * p] - 5.0));
  CHECK(closest < 1.0);
  // The screen-space derivatives too.
  auto derivatives = [](const ClippedScene& sc) {
    std::vector<double> dx(2 * sc.W * sc.H), dy(2 * sc.W * sc.H);
    interpolate_derivatives(image_params(sc.attr.data(), 3, 2, sc.clip.data(), sc.tris.data(), 1, sc.id.data(), sc.uv.data(), sc.W, sc.H, true), dx.data(), dy.data());
    dx.insert(dx.end(), dy.begin(), dy.end());
    return dx;
  };
  const std::vector<double> da = derivatives(plus), db = derivatives(zero), dc = derivatives(minus);
  CHECK(all_finite(db));
  CHECK(max_abs_diff(da, db) < 1e-12);
  CHECK(max_abs_diff(dc, db) < 1e-12);
  double largest = 0;
  for (double d : db) largest = std::max(largest, std::abs(d));
  CHECK(largest > 1e-3);
}

TEST_CASE("interpolate: gradients to x, y, w of a clipped triangle match finite differences, also at w = 0",
          "[raster][interpolate][near][gradient]") {
  for (double w2 : {-0.6, -1e-7, 0.0, 1e-7}) {
    INFO("w2 = " << w2);
    const ClippedScene s(w2);
    const std::vector<double> wts = random_vector(2 * s.W * s.H, -1, 1, 17);
    auto loss = [&](const std::vector<double>& c) {
      const std::vector<double> out = s.forward(c);
      double l = 0;
      for (std::size_t i = 0; i < out.size(); ++i) l += wts[i] * out[i];
      return l;
    };
    std::vector<double> ga(6, 0.0), gc(12, 0.0), gu(2 * s.W * s.H, 0.0);
    interpolate_backward(
        image_params(s.attr.data(), 3, 2, s.clip.data(), s.tris.data(), 1, s.id.data(), s.uv.data(), s.W, s.H, true),
        wts.data(), {ga.data(), gc.data(), gu.data()});
    CHECK(all_finite(gc));
    const double ec = fd_error(loss, s.clip, gc, 1e-8);
    INFO("relative error clip " << ec);
    CHECK(ec < 1e-6);
    // z does not enter; uv is not read for clipped triangles, so it gets no gradient.
    for (int k = 0; k < 3; ++k) CHECK(gc[4 * k + 2] == 0);
    CHECK(std::all_of(gu.begin(), gu.end(), [](double x) { return x == 0; }));
  }
}
