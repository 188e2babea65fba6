// interpolate (ops/render/interpolate.h): the linear blend of the attributes with the
// G-buffer's perspective-correct barycentrics, against the pixel ray's
// barycentrics (tests/ops/pixel_ray.h), and float64 gradient checks w.r.t.
// the attributes, the G-buffer's uv, and (through rasterize) clip.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "ops/ops.h"
#include "ops/pixel_ray.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {
Tensor clip_of_two_triangles() {
  return Tensor::from_values({-0.9, -0.8, 0.1, 1.0, 0.9, -0.7, 0.2, 2.0, -0.2, 0.9, 0.3, 0.7,  //
                              0.2, 0.1, -0.1, 1.5, 0.95, 0.9, 0.0, 1.1, -0.6, 0.5, 0.2, 0.8},
                             {6, 4}, DType::Float64);
}
Tensor two_tris() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3}); }

// Hard single triangles: crossing w = 0 and the near plane (vertex 1 behind
// the eye, vertex 2 on the eye plane), a sliver, a floor at a grazing angle.
std::vector<Tensor> hard_triangles() {
  return {Tensor::from_values({-0.6, -0.5, -0.8, 1.0, 0.7, -0.4, 1.3, 1.5, 0.3, -0.8, -0.6, 0.0}, {3, 4},
                              DType::Float64),
          Tensor::from_values({-0.9, 0.5, 0.0, 1.0, 0.9, 0.53, 0.1, 1.0, 0.9, 0.6, 0.1, 1.0}, {3, 4},
                              DType::Float64),
          Tensor::from_values({-0.5, -0.3, 0.4, 0.6, 0.5, -0.3, 0.4, 0.6, 0.05, -0.3, 7.9, 8.0}, {3, 4},
                              DType::Float64)};
}
}  // namespace

TEST_CASE("interpolate op: values are the attributes blended with the pixel ray's barycentrics",
          "[ops][interpolate]") {
  std::vector<Tensor> scenes = hard_triangles();
  scenes.insert(scenes.begin(), clip_of_two_triangles());
  for (std::size_t s = 0; s < scenes.size(); ++s) {
    INFO("scene " << s);
    const Tensor clip = scenes[s];
    const Tensor tris = s == 0 ? two_tris() : Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
    const Tensor attr = Tensor::uniform({clip.size(0), 3}, -1, 1, 7 + s, DType::Float64);
    const GBuffer gb = rasterize(clip, tris, {20, 16});
    const std::vector<double> out = interpolate(attr, gb, tris).to_vector(), a = attr.to_vector(),
                              id = gb.tri_id.to_vector(), c = clip.to_vector();
    const std::vector<std::int32_t> t(tris.data<std::int32_t>(), tris.data<std::int32_t>() + tris.numel());
    int covered = 0;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 20; ++x) {
        const int p = y * 20 + x;
        if (id[p] == 0) {
          for (int ch = 0; ch < 3; ++ch) CHECK(out[3 * p + ch] == 0);
          continue;
        }
        ++covered;
        const int tri = static_cast<int>(id[p]) - 1;
        const gr::testing::PixelRay r =
            gr::testing::pixel_ray(c, t, tri, gr::testing::ndc_x(x + 0.5, 20), gr::testing::ndc_y(y + 0.5, 16));
        for (int ch = 0; ch < 3; ++ch) {
          double want = 0;
          for (int k = 0; k < 3; ++k) want += r.b[k] * a[3 * t[3 * tri + k] + ch];
          CHECK(out[3 * p + ch] == Approx(want).margin(1e-12));
        }
      }
    CHECK(covered > 2);
  }
}

TEST_CASE("interpolate op: gradients w.r.t. attributes and barycentrics match finite differences",
          "[ops][interpolate][gradcheck]") {
  const Tensor tris = two_tris();
  Tensor attr = random_input({6, 3}, -1, 1, 41);
  GBuffer gb = rasterize(clip_of_two_triangles(), tris, {20, 16});
  gb.uv = gb.uv.copy().set_requires_grad();  // check dL/du, dL/dv as a leaf
  require_gradcheck("interpolate (attributes, uv)",
                    [&](const Inputs& in) {
                      GBuffer g = gb;
                      g.uv = in[1];
                      return interpolate(in[0], g, tris);
                    },
                    {attr, gb.uv});
}

TEST_CASE("interpolate op: gradients w.r.t. clip through rasterize match finite differences, random and hard "
          "triangles", "[ops][interpolate][gradcheck][near]") {
  const Tensor tris = two_tris();
  Tensor attr = random_input({6, 3}, -1, 1, 42);
  require_gradcheck("interpolate through rasterize (clip, attributes)",
                    [&](const Inputs& in) { return interpolate(in[1], rasterize(in[0], tris, {20, 16}), tris); },
                    {clip_of_two_triangles().set_requires_grad(), attr}, GradcheckOptions{1e-6});
  const Tensor one = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  const std::vector<Tensor> hard = hard_triangles();
  for (std::size_t k = 0; k < hard.size(); ++k) {
    INFO("hard triangle " << k << " (near-plane crossing with w = 0, sliver, grazing)");
    Tensor a = random_input({3, 2}, -1, 1, 50 + k);
    GradcheckOptions opt;
    opt.eps = 1e-7;  // the coverage must not change
    opt.rtol = 1e-5;
    require_gradcheck("interpolate through rasterize (hard " + std::to_string(k) + ")",
                      [&](const Inputs& in) { return interpolate(in[1], rasterize(in[0], one, {20, 16}), one); },
                      {hard[k].copy().set_requires_grad(), a}, opt);
  }
}

TEST_CASE("interpolate op: vertices a denormal w from the eye plane give finite values, derivatives and gradients",
          "[ops][interpolate][near]") {
  // Found by fuzz_raster (tests/fuzz/corpus/raster/raster_d_dx_nan.bin): two
  // vertices at w = 1e-310 (on the eye plane but for a denormal).
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  Tensor attr = random_input({3, 4}, -1, 1, 47).set_requires_grad();
  auto clip_with_w = [](double w) {
    return Tensor::from_values({w, w, w, w, 5.0, -3.4375, 0.0, 3.21875, -1.0625, w, w, w}, {3, 4}, DType::Float64);
  };
  Tensor clip = clip_with_w(1e-310).set_requires_grad();
  RasterizeOptions o{11, 8};
  o.derivatives = true;
  const GBuffer gb = rasterize(clip, tris, o);
  const std::vector<double> ids = gb.tri_id.to_vector();
  REQUIRE(std::count(ids.begin(), ids.end(), 1.0) > 0);
  const InterpolatedWithDerivatives d = interpolate_with_derivatives(attr, gb, tris);
  for (const Tensor& t : {d.values, d.d_dx, d.d_dy})
    for (const double v : t.to_vector()) REQUIRE(std::isfinite(v));
  backward(sum(d.values) + sum(d.d_dx) + sum(d.d_dy));
  for (const Tensor& t : {clip.grad(), attr.grad()})
    for (const double v : t.to_vector()) REQUIRE(std::isfinite(v));
  // The values are the pixel ray's blend.
  const std::vector<double> c = clip.detach().to_vector(), a = attr.detach().to_vector(), v = d.values.to_vector();
  for (int p = 0; p < 11 * 8; ++p) {
    if (ids[p] == 0) continue;
    const gr::testing::PixelRay r = gr::testing::pixel_ray(c, {0, 1, 2}, 0, gr::testing::ndc_x(p % 11 + 0.5, 11),
                                                           gr::testing::ndc_y(p / 11 + 0.5, 8));
    for (int ch = 0; ch < 4; ++ch)
      REQUIRE(v[4 * p + ch] == Approx(r.b[0] * a[ch] + r.b[1] * a[4 + ch] + r.b[2] * a[8 + ch]).margin(1e-12));
  }
}

TEST_CASE("interpolate op: constant attributes stay constant and background gets the chosen value", "[ops][interpolate]") {
  Tensor clip = clip_of_two_triangles();
  Tensor tris = two_tris();
  GBuffer gb = rasterize(clip, tris, {16, 16});
  Tensor attr = Tensor::full({6, 2}, 0.375, DType::Float64);  // the barycentrics sum to one
  InterpolateOptions opt;
  opt.background = Tensor::from_values({-7, 9}, {2}, DType::Float64);
  Tensor out = interpolate(attr, gb, tris, opt);
  for (std::int64_t j = 0; j < 16; ++j)
    for (std::int64_t i = 0; i < 16; ++i) {
      const bool covered = gb.tri_id.at({j, i}) != 0;
      CHECK(out.at({j, i, 0}) == (covered ? Approx(0.375).epsilon(1e-14) : Approx(-7)));
      CHECK(out.at({j, i, 1}) == (covered ? Approx(0.375).epsilon(1e-14) : Approx(9)));
    }
}

TEST_CASE("interpolate op: mismatched shapes and dtypes throw with clear messages", "[ops][interpolate][errors]") {
  Tensor clip = clip_of_two_triangles();
  Tensor tris = two_tris();
  GBuffer gb = rasterize(clip, tris, {8, 8});
  CHECK_THROWS_WITH(interpolate(Tensor::ones({5, 3}, DType::Float64), gb, tris),
                    Catch::Contains("attributes") && Catch::Contains("N = 6"));
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}), gb, tris), DTypeError);
  InterpolateOptions opt;
  opt.background = Tensor::ones({2}, DType::Float64);
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}, DType::Float64), gb, tris, opt), ShapeError);
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}, DType::Float64), GBuffer{}, tris), ShapeError);
  const Tensor attr = Tensor::ones({6, 3}, DType::Float64);
  GBuffer bad_ids = gb;
  bad_ids.tri_id = gb.tri_id.copy();
  bad_ids.tri_id.data<std::int32_t>()[3] = 3;
  CHECK_THROWS_AS(interpolate(attr, bad_ids, tris), IndexError);
  CHECK_THROWS_WITH(interpolate(attr, bad_ids, tris), Catch::Contains("tri_id[3]"));
  const Tensor bad_tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 6, 5}, {2, 3});
  CHECK_THROWS_AS(interpolate(attr, gb, bad_tris), IndexError);
  CHECK_THROWS_WITH(interpolate(attr, gb, bad_tris), Catch::Contains("tris[1][1]"));
  GBuffer empty;
  empty.tri_id = Tensor::zeros({0, 8}, DType::Int32);
  empty.uv = Tensor::zeros({0, 8, 2}, DType::Float64);
  CHECK_THROWS_AS(interpolate(attr, empty, tris), ValueError);
  GBuffer short_uv = gb;
  short_uv.uv = Tensor::zeros({8, 8, 1}, DType::Float64);
  CHECK_THROWS_WITH(interpolate(attr, short_uv, tris), Catch::Contains("gbuffer.uv"));
}

TEST_CASE("interpolate and antialias op: triangles or a clip other than the rasterized ones are refused, naming the "
          "argument - a copy with the same values is accepted", "[ops][interpolate][antialias][errors]") {
  const Tensor clip = clip_of_two_triangles();
  const Tensor tris = two_tris();
  const GBuffer gb = rasterize(clip, tris, {8, 8});
  const Tensor attr = Tensor::ones({6, 3}, DType::Float64);
  const Tensor image = Tensor::ones({8, 8, 3}, DType::Float64);
  CHECK_NOTHROW(interpolate(attr, gb, tris.copy()));
  CHECK_NOTHROW(antialias(image, gb, clip.copy(), tris.copy()));
  Tensor moved = clip.copy();
  moved.data<double>()[5] += 1e-9;
  CHECK_THROWS_WITH(antialias(image, gb, moved, tris),
                    Catch::Contains("antialias: argument 'clip'") &&
                        Catch::Contains("not the clip the G-buffer was rasterized from"));
  const Tensor swapped = Tensor::from_vector<std::int32_t>({3, 4, 5, 0, 1, 2}, {2, 3});
  CHECK_THROWS_WITH(interpolate(attr, gb, swapped), Catch::Contains("'triangles'"));
  CHECK_THROWS_WITH(antialias(image, gb, clip, swapped), Catch::Contains("'triangles'"));
  // A G-buffer that records no clip (made by hand) is interpolated as it is:
  // the blend needs only its uv and ids.
  GBuffer fixed = gb;
  fixed.clip = Tensor();
  fixed.triangles = Tensor();
  CHECK(interpolate(attr, fixed, swapped).to_vector() == interpolate(attr, gb, tris).to_vector());
}

TEST_CASE("interpolate op: adjoints sharing the G-buffer's grouping by triangle and of corners by vertex give the "
          "bits of adjoints grouping on their own",
          "[ops][interpolate][rasterize]") {
  auto gradients = [](bool shared) {
    Tensor clip = clip_of_two_triangles().set_requires_grad();
    Tensor attr = random_input({6, 3}, -1, 1, 9).set_requires_grad();
    const Tensor tris = two_tris();
    RasterizeOptions ro{64, 48};
    ro.derivatives = true;
    GBuffer gb = rasterize(clip, tris, ro);
    REQUIRE(gb.groups);  // recorded, one image
    if (!shared) gb.groups.reset();  // each interpolate adjoint groups its pixels itself
    InterpolateOptions io;
    io.diff_attrs = {0, 2};
    const InterpolatedWithDerivatives d = interpolate_with_derivatives(attr, gb, tris, io);
    const Tensor colour = interpolate(attr * attr, gb, tris);
    backward(sum(d.values * colour) + sum(d.d_dx * d.d_dx) + sum(d.d_dy) + sum(gb.depth));
    std::vector<double> g = clip.grad().to_vector();
    for (double x : attr.grad().to_vector()) g.push_back(x);
    return g;
  };
  const std::vector<double> shared = gradients(true), own = gradients(false);
  REQUIRE(shared.size() == own.size());
  CHECK(std::equal(shared.begin(), shared.end(), own.begin(),
                   [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }));
}
