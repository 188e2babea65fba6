// Tests of the SSR ops (ops/render/ssr.*): gradchecks of the compositing w.r.t. the
// colour buffer, the reflectivity and the four fade parameters (circular and
// vignette edge fades); tensor-op fades equal the tracer's plain fades; a hand
// case where the hit is a pixel centre; pixels without a hit keep their colour
// and pass its gradient straight through; the hit search records nothing on
// the tape while gradients still reach vertex colours through the G-buffer;
// shape errors name the argument.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/tensor/elementwise.h"
#include "ops/tensor/reduce.h"
#include "ops/tensor/shape_ops.h"
#include "ops/render/ssr.h"
#include "ops/render/transforms.h"
#include "examples/common/ssr_scene.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {

Tensor vec3(const std::array<double, 3>& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}, DType::Float64); }

struct Pass {
  SsrGBuffer g;
  Tensor proj;
  Tensor colours;  // vertex colours (float64)
};

// The SSR scene as a float64 G-buffer; vertex colours optionally require grad.
Pass render(int W, int H, bool colours_grad = false) {
  const gr::examples::SsrScene s = gr::examples::make_ssr_scene(8, 3);
  Pass p;
  const Tensor view = look_at(vec3(s.eye), vec3(s.target), vec3(s.up));
  p.proj = perspective(s.fov_y, double(W) / H, s.near, s.far, ClipSpace::OpenGL, DType::Float64);
  p.colours = cast(s.colours, DType::Float64);
  if (colours_grad) p.colours.set_requires_grad();
  const ViewSpaceMesh vs = ssr_view_space(cast(s.mesh.positions, DType::Float64), cast(s.mesh.normals, DType::Float64), view);
  p.g = ssr_gbuffer(vs.positions, vs.normals, p.colours, s.mesh.triangles, p.proj, {W, H});
  return p;
}

SsrOptions options(EdgeFade form) {
  SsrOptions o;
  o.tracer = SsrTracer::Dda;
  o.max_distance = 8;
  o.thickness = 0.3;
  o.binary_steps = 6;
  o.edge_form = form;
  // Keep every fade strictly inside (0, 1) so finite differences stay on one piece.
  o.edge_distance = 12;
  o.edge_exponent = 1.7;
  o.fade_distance = 12;
  o.fade_exponent = 1.5;
  return o;
}

}  // namespace

TEST_CASE("ssr_composite: gradient w.r.t. colour buffer, reflectivity and fade parameters matches finite "
          "differences",
          "[ops][ssr][gradcheck]") {
  const int W = 32, H = 24;
  const Pass p = render(W, H);
  for (EdgeFade form : {EdgeFade::Circular, EdgeFade::Vignette}) {
    const SsrOptions o = options(form);
    const SsrTrace t = ssr_trace(p.g, p.proj, o);
    REQUIRE(t.stats.hits > 40);
    const std::vector<Tensor> inputs = {random_input({H, W, 3}, 0, 1, 1), random_input({H, W, 1}, 0.2, 0.8, 2),
                                        random_input({1}, 10, 14, 3), random_input({1}, 1.2, 2.2, 4),
                                        random_input({1}, 10, 14, 5), random_input({1}, 1.2, 2.2, 6)};
    auto f = [&](const std::vector<Tensor>& in) {
      SsrFade fade;
      fade.form = form;
      fade.edge_distance = in[2], fade.edge_exponent = in[3], fade.fade_distance = in[4], fade.fade_exponent = in[5];
      const SsrComposite c = ssr_composite(in[0], t, in[1], fade);
      return concat({c.image, c.reflection, c.confidence}, 2);
    };
    // Default step. The vignette's clamp at 1 is a kink that some pixels sit near,
    // which bounds its measured error (~4e-7) rather than the adjoint.
    require_gradcheck(form == EdgeFade::Circular ? "ssr_composite circular" : "ssr_composite vignette", f, inputs);
    // The circular form does not use edge_distance: nothing connects it to the output.
    if (form == EdgeFade::Circular) {
      SsrFade fade = ssr_fade(o, DType::Float64);
      fade.edge_distance = Tensor::full({1}, 12.0, DType::Float64).set_requires_grad();
      CHECK_FALSE(ssr_composite(inputs[0].detach(), t, inputs[1].detach(), fade).image.requires_grad());
    }
  }
}

TEST_CASE("ssr_composite: the tensor-op fades equal the tracer's plain fades", "[ops][ssr]") {
  const Pass p = render(64, 48);
  for (EdgeFade form : {EdgeFade::Circular, EdgeFade::Vignette}) {
    const SsrOptions o = options(form);
    const SsrTrace t = ssr_trace(p.g, p.proj, o);
    const SsrFade fade = ssr_fade(o, DType::Float64);
    const auto e = ssr_edge_fade(t, fade).to_vector(), d = ssr_distance_fade(t, fade).to_vector();
    const auto hit = t.hit.to_vector(), pe = t.edge_fade.to_vector(), pd = t.distance_fade.to_vector();
    const auto conf = ssr_confidence(t, fade).to_vector();
    int hits = 0;
    for (std::size_t k = 0; k < hit.size(); ++k) {
      if (hit[k] == 0) {
        REQUIRE(conf[k] == 0);
        continue;
      }
      ++hits;
      REQUIRE(e[k] == Approx(pe[k]).margin(1e-12));
      REQUIRE(d[k] == Approx(pd[k]).margin(1e-12));
      REQUIRE(conf[k] == Approx(pe[k] * pd[k]).margin(1e-12));
    }
    CHECK(hits > 200);
  }
}

TEST_CASE("ssr_composite: a hit on a pixel centre reflects that pixel's colour, and misses keep the base colour and "
          "pass its gradient through",
          "[ops][ssr]") {
  // Hand-made 2 x 3 trace: pixel (0, 0) hits the centre of pixel (2, 1) at distance 1; the rest miss.
  const int W = 3, H = 2;
  SsrTrace t;
  t.width = W, t.height = H;
  std::vector<double> hit(W * H, 0), xy(2 * W * H), dist(W * H, 0);
  for (int k = 0; k < W * H; ++k) xy[2 * k] = 1.5, xy[2 * k + 1] = 1.0;
  hit[0] = 1, xy[0] = 2.5, xy[1] = 1.5, dist[0] = 1;
  t.hit = Tensor::from_vector(hit, {H, W, 1});
  t.hit_xy = Tensor::from_vector(xy, {H, W, 2});
  std::vector<double> uv(2 * W * H);
  for (int k = 0; k < W * H; ++k) uv[2 * k] = xy[2 * k] / W, uv[2 * k + 1] = 1 - xy[2 * k + 1] / H;
  t.hit_uv = Tensor::from_vector(uv, {H, W, 2});
  t.hit_distance = Tensor::from_vector(dist, {H, W, 1});
  Tensor colour = Tensor::uniform({H, W, 3}, 0, 1, 7, DType::Float64);
  colour.set_requires_grad();
  SsrFade fade;
  fade.form = EdgeFade::Circular;
  fade.edge_distance = Tensor::full({1}, 1.0, DType::Float64);
  fade.edge_exponent = Tensor::full({1}, 2.0, DType::Float64);
  fade.fade_distance = Tensor::full({1}, 2.0, DType::Float64);
  fade.fade_exponent = Tensor::full({1}, 1.0, DType::Float64);
  const Tensor refl = Tensor::full({1}, 0.5, DType::Float64);
  const SsrComposite c = ssr_composite(colour, t, refl, fade);
  // Edge: a = 2.5/3, b = 0.75 -> r^2 = 4 ((1/3)^2 + (1/4)^2); distance fade 1 - 1/2.
  const double r2 = 4 * (1.0 / 9 + 1.0 / 16), conf = (1 - r2) * 0.5, a = 0.5 * conf;
  const auto col = colour.to_vector(), img = c.image.to_vector(), refl_out = c.reflection.to_vector();
  const int src = 1 * W + 2;
  for (int ch = 0; ch < 3; ++ch) {
    CHECK(refl_out[ch] == Approx(col[3 * src + ch] * conf).epsilon(1e-12));
    CHECK(img[ch] == Approx(col[ch] + a * (col[3 * src + ch] - col[ch])).epsilon(1e-12));
  }
  for (int k = 1; k < W * H; ++k)
    for (int ch = 0; ch < 3; ++ch) {
      CHECK(img[3 * k + ch] == col[3 * k + ch]);
      CHECK(refl_out[3 * k + ch] == 0);
    }
  backward(sum(c.image));
  const auto g = colour.grad().to_vector();
  // Pixel 0 keeps 1 - a of its own gradient; the source pixel gets its own 1 plus a.
  for (int ch = 0; ch < 3; ++ch) {
    CHECK(g[ch] == Approx(1 - a).epsilon(1e-12));
    CHECK(g[3 * src + ch] == Approx(1 + a).epsilon(1e-12));
    CHECK(g[3 * 1 + ch] == Approx(1.0).epsilon(1e-12));
  }
}

TEST_CASE("ssr_trace: the hit search records nothing on the tape, yet gradients reach the vertex colours through "
          "the G-buffer",
          "[ops][ssr]") {
  const Pass p = render(48, 36, /*colours_grad=*/true);
  const std::size_t before = Tape::current().size();
  const SsrTrace t = ssr_trace(p.g, p.proj, options(EdgeFade::Circular));
  CHECK(Tape::current().size() == before);
  CHECK_FALSE(t.hit.requires_grad());
  CHECK_FALSE(t.hit_uv.requires_grad());
  CHECK_FALSE(t.hit_distance.requires_grad());
  const SsrComposite c = ssr_composite(p.g.colour, t, Tensor::full({1}, 0.6, DType::Float64),
                                       ssr_fade(options(EdgeFade::Circular), DType::Float64));
  for (const Tensor* x : {&c.image, &c.reflection, &c.confidence}) CHECK(gr::testing::all_finite(*x));
  backward(sum(c.image));
  REQUIRE(p.colours.grad().defined());
  CHECK(gr::testing::all_finite(p.colours.grad()));
  double total = 0;
  for (double v : p.colours.grad().to_vector()) total += v;
  CHECK(total > 0);
}

TEST_CASE("ssr ops: wrong shapes and dtypes throw naming the argument", "[ops][ssr]") {
  const Pass p = render(16, 12);
  const SsrOptions o = options(EdgeFade::Circular);
  CHECK_THROWS_WITH(ssr_trace(p.g.position, p.g.normal, p.g.mask, reshape(p.proj, {16}), o),
                    Catch::Contains("projection"));
  CHECK_THROWS_AS(ssr_trace(p.g.position, slice(p.g.normal, 0, 0, 6), p.g.mask, p.proj, o), ShapeError);
  CHECK_THROWS_AS(ssr_trace(p.g.position, p.g.normal, cast(p.g.mask, DType::Float64), p.proj, o), DTypeError);
  const SsrTrace t = ssr_trace(p.g, p.proj, o);
  CHECK_THROWS_AS(ssr_composite(slice(p.g.colour, 0, 0, 6), t, Tensor::full({1}, 0.5, DType::Float64),
                                ssr_fade(o, DType::Float64)),
                  ShapeError);
  CHECK_THROWS_AS(ssr_composite(cast(p.g.colour, DType::Float32), t, Tensor::full({1}, 0.5, DType::Float32),
                                ssr_fade(o, DType::Float32)),
                  DTypeError);
}
