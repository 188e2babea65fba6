#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "ops/ops.h"
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
}  // namespace

TEST_CASE("interpolate op: gradients w.r.t. attributes, w and barycentrics match finite differences", "[ops][interpolate][gradcheck]") {
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  Tensor attr = random_input({6, 3}, -1, 1, 41);
  for (bool perspective : {true, false}) {
    INFO("perspective " << perspective);
    Tensor clip = clip_of_two_triangles().set_requires_grad();
    GBuffer gb = rasterize(clip.detach(), tris, {20, 16});
    gb.uv = gb.uv.copy().set_requires_grad();  // check dL/du, dL/dv as a leaf
    InterpolateOptions opt;
    opt.perspective = perspective;
    require_gradcheck(perspective ? "interpolate perspective" : "interpolate linear",
                      [&](const Inputs& in) {
                        GBuffer g = gb;
                        g.uv = in[2];
                        return interpolate(in[0], in[1], g, tris, opt);
                      },
                      {attr, clip, gb.uv});
  }
}

TEST_CASE("interpolate op: gradients of a near-clipped triangle with a vertex at w = 0 match finite differences",
          "[ops][interpolate][gradcheck][near]") {
  // Vertex 1 is behind the camera, vertex 2 exactly on the eye plane (w = 0):
  // the clipped form takes q_k = F_k / D from x, y, w of clip.
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  Tensor attr = random_input({3, 3}, -1, 1, 43);
  Tensor clip = Tensor::from_values({-0.6, -0.5, -0.8, 1.0, 0.7, -0.4, 1.3, 1.5, 0.3, -0.8, -0.6, 0.0}, {3, 4},
                                    DType::Float64)
                    .set_requires_grad();
  GBuffer gb = rasterize(clip.detach(), tris, {20, 16});
  gb.uv = gb.uv.copy().set_requires_grad();
  require_gradcheck("interpolate clipped, w = 0",
                    [&](const Inputs& in) {
                      GBuffer g = gb;
                      g.uv = in[2];
                      return interpolate(in[0], in[1], g, tris);
                    },
                    {attr, clip, gb.uv});
}

TEST_CASE("interpolate op: vertices a denormal w from the eye plane give the w = 0 values, finite derivatives and gradients",
          "[ops][interpolate][near]") {
  // Found by fuzz_raster (tests/fuzz/corpus/raster/raster_d_dx_nan.bin): two
  // vertices at w = 1e-310 made lambda_k / w_k overflow (the rasterizer's u had
  // saturated), so d_dx was NaN. Such vertices take the clipped form, as at w = 0.
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  Tensor attr = random_input({3, 4}, -1, 1, 47).set_requires_grad();
  auto clip_with_w = [](double w) {
    return Tensor::from_values({w, w, w, w, 5.0, -3.4375, 0.0, 3.21875, -1.0625, w, w, w}, {3, 4}, DType::Float64);
  };
  Tensor clip = clip_with_w(1e-310).set_requires_grad();
  const GBuffer gb = rasterize(clip.detach(), tris, {11, 8});
  const std::vector<double> ids = gb.tri_id.to_vector();
  REQUIRE(std::count(ids.begin(), ids.end(), 1.0) > 0);
  const InterpolatedWithDerivatives d = interpolate_with_derivatives(attr, clip, gb, tris);
  for (const Tensor& t : {d.values, d.d_dx, d.d_dy})
    for (const double v : t.to_vector()) REQUIRE(std::isfinite(v));
  backward(sum(d.values) + sum(d.d_dx) + sum(d.d_dy));
  for (const Tensor& t : {clip.grad(), attr.grad()})
    for (const double v : t.to_vector()) REQUIRE(std::isfinite(v));
  // Same weights as a vertex exactly on the eye plane, at the same pixels.
  // (Other positions over this coverage: a G-buffer that records no clip.)
  GBuffer coverage = gb;
  coverage.clip = Tensor();
  const Tensor at_zero = interpolate(attr.detach(), clip_with_w(0.0), coverage, tris);
  const std::vector<double> a = d.values.to_vector(), b = at_zero.to_vector();
  for (std::size_t i = 0; i < a.size(); ++i) REQUIRE(a[i] == Approx(b[i]).margin(1e-12));
}

TEST_CASE("interpolate op: constant attributes stay constant and background gets the chosen value", "[ops][interpolate]") {
  Tensor clip = clip_of_two_triangles();
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  GBuffer gb = rasterize(clip, tris, {16, 16});
  Tensor attr = Tensor::full({6, 2}, 0.375, DType::Float64);  // barycentrics sum to one in both modes
  InterpolateOptions opt;
  opt.background = Tensor::from_values({-7, 9}, {2}, DType::Float64);
  for (bool perspective : {true, false}) {
    opt.perspective = perspective;
    Tensor out = interpolate(attr, clip, gb, tris, opt);
    for (std::int64_t j = 0; j < 16; ++j)
      for (std::int64_t i = 0; i < 16; ++i) {
        const bool covered = gb.tri_id.at({j, i}) != 0;
        CHECK(out.at({j, i, 0}) == (covered ? Approx(0.375).epsilon(1e-14) : Approx(-7)));
        CHECK(out.at({j, i, 1}) == (covered ? Approx(0.375).epsilon(1e-14) : Approx(9)));
      }
  }
}

TEST_CASE("interpolate op: mismatched shapes and dtypes throw with clear messages", "[ops][interpolate][errors]") {
  Tensor clip = clip_of_two_triangles();
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  GBuffer gb = rasterize(clip, tris, {8, 8});
  CHECK_THROWS_WITH(interpolate(Tensor::ones({5, 3}, DType::Float64), clip, gb, tris),
                    Catch::Contains("attributes") && Catch::Contains("N = 6"));
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}), clip, gb, tris), DTypeError);
  InterpolateOptions opt;
  opt.background = Tensor::ones({2}, DType::Float64);
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}, DType::Float64), clip, gb, tris, opt), ShapeError);
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}, DType::Float64), clip, GBuffer{}, tris), ShapeError);
  const Tensor attr = Tensor::ones({6, 3}, DType::Float64);
  GBuffer bad_ids = gb;
  bad_ids.tri_id = gb.tri_id.copy();
  bad_ids.tri_id.data<std::int32_t>()[3] = 3;
  CHECK_THROWS_AS(interpolate(attr, clip, bad_ids, tris), IndexError);
  CHECK_THROWS_WITH(interpolate(attr, clip, bad_ids, tris), Catch::Contains("tri_id[3]"));
  const Tensor bad_tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 6, 5}, {2, 3});
  CHECK_THROWS_AS(interpolate(attr, clip, gb, bad_tris), IndexError);
  CHECK_THROWS_WITH(interpolate(attr, clip, gb, bad_tris), Catch::Contains("tris[1][1]"));
  GBuffer empty;
  empty.tri_id = Tensor::zeros({0, 8}, DType::Int32);
  empty.uv = Tensor::zeros({0, 8, 2}, DType::Float64);
  CHECK_THROWS_AS(interpolate(attr, clip, empty, tris), ValueError);
}

TEST_CASE("interpolate op: adjoints share one G-buffer's grouping by triangle, and a copy given another tri_id "
          "groups its own pixels", "[ops][interpolate][rasterize]") {
  // Two interpolations and the rasterize adjoint over one G-buffer share its
  // groups; a copy of it with another image's tri_id and uv must not reuse
  // them, in either order of the adjoints. The reference runs without groups.
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  Tensor attr = random_input({6, 3}, -1, 1, 43).set_requires_grad();
  Tensor weights = random_input({16, 20, 3}, -1, 1, 44);
  const Tensor clip0 = clip_of_two_triangles();
  const Tensor moved = clip0 * Tensor::from_values({0.8, 1.1, 1.0, 1.0}, {4}, DType::Float64);
  for (bool mixed_first : {false, true}) {
    INFO("mixed copy recorded first " << mixed_first);
    auto grads = [&](bool shared) {
      Tensor clip = clip0.copy().set_requires_grad();
      GBuffer gb = rasterize(clip, tris, {20, 16});
      GBuffer other = rasterize(moved, tris, {20, 16});
      GBuffer mixed = gb;  // gb's groups, other's pixels
      mixed.tri_id = other.tri_id;
      mixed.uv = other.uv;
      if (!shared) gb.groups.reset(), mixed.groups.reset();
      REQUIRE((shared ? mixed.groups == gb.groups && gb.groups != nullptr : !gb.groups));
      Tensor a = mixed_first ? interpolate(attr, clip, mixed, tris) : interpolate(attr, clip, gb, tris);
      Tensor b = mixed_first ? interpolate(attr, clip, gb, tris) : interpolate(attr, clip, mixed, tris);
      Tensor c = interpolate(attr * 2.0, clip, gb, tris);
      backward(sum((a + b * 3.0 + c) * weights));
      std::vector<Tensor> g = {attr.grad().copy(), clip.grad().copy()};
      attr.zero_grad();
      return g;
    };
    const std::vector<Tensor> ref = grads(false), got = grads(true);
    for (std::size_t i = 0; i < ref.size(); ++i) REQUIRE(got[i].to_vector() == ref[i].to_vector());
    const std::vector<double> ga = ref[0].to_vector();
    REQUIRE(std::any_of(ga.begin(), ga.end(), [](double x) { return x != 0.0; }));
  }
}

TEST_CASE("interpolate op: a G-buffer given a new tri_id after a backward never reuses the old grouping, even "
          "where the new buffer could take the old one's memory", "[ops][interpolate][rasterize]") {
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  Tensor attr = random_input({6, 3}, -1, 1, 45).set_requires_grad();
  Tensor weights = random_input({16, 20, 3}, -1, 1, 46);
  const Tensor moved = clip_of_two_triangles() * Tensor::from_values({0.8, 1.1, 1.0, 1.0}, {4}, DType::Float64);
  auto attr_grad = [&](const GBuffer& gb, const Tensor& clip) {
    backward(sum(interpolate(attr, clip, gb, tris) * weights));
    const std::vector<double> g = attr.grad().to_vector();
    attr.zero_grad();
    return g;
  };
  Tensor clip = clip_of_two_triangles().set_requires_grad();
  GBuffer gb = rasterize(clip, tris, {20, 16});
  attr_grad(gb, clip);  // groups gb's pixels
  // Replace tri_id by the moved scene's ids, in a buffer of the same size
  // allocated right after the old one is dropped.
  const GBuffer other = rasterize(moved, tris, {20, 16});
  gb.tri_id = Tensor();
  gb.tri_id = Tensor::empty({16, 20}, DType::Int32);
  std::copy(other.tri_id.data<std::int32_t>(), other.tri_id.data<std::int32_t>() + 16 * 20,
            gb.tri_id.data<std::int32_t>());
  gb.uv = other.uv;
  gb.clip = moved;
  GBuffer fresh = gb;
  fresh.groups.reset();
  const std::vector<double> reused = attr_grad(gb, moved), ungrouped = attr_grad(fresh, moved);
  REQUIRE(std::any_of(ungrouped.begin(), ungrouped.end(), [](double x) { return x != 0.0; }));
  CHECK(reused == ungrouped);
}

TEST_CASE("interpolate op: the three-argument form takes clip from the G-buffer and gives the four-argument form's "
          "values and gradients, bit for bit", "[ops][interpolate]") {
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  const Tensor weights = random_input({16, 20, 3}, -1, 1, 53);
  auto run = [&](bool from_gbuffer) {
    Tensor clip = clip_of_two_triangles().set_requires_grad();
    Tensor attr = random_input({6, 3}, -1, 1, 41).set_requires_grad();
    const GBuffer gb = rasterize(clip, tris, {20, 16});
    const Tensor out = from_gbuffer ? interpolate(attr, gb, tris) : interpolate(attr, clip, gb, tris);
    backward(sum(out * weights));
    return std::vector<std::vector<double>>{out.to_vector(), attr.grad().to_vector(), clip.grad().to_vector()};
  };
  const auto three = run(true), four = run(false);
  REQUIRE(three == four);
  double largest = 0;
  for (const double g : three[2]) largest = std::max(largest, std::fabs(g));
  REQUIRE(largest > 0);  // the clip gradient flows through the G-buffer's clip
  const Tensor attr = random_input({6, 3}, -1, 1, 41);
  const GBuffer gb = rasterize(clip_of_two_triangles(), tris, {20, 16});
  require_gradcheck("interpolate(attributes, gbuffer, triangles)",
                    [&](const Inputs& in) { return interpolate(in[0], gb, tris); }, {attr});
}

TEST_CASE("interpolate and antialias op: a clip or triangles other than the rasterized ones are refused, naming the "
          "argument; a copy with the same values is accepted", "[ops][interpolate][antialias][errors]") {
  const Tensor clip = clip_of_two_triangles();
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  const GBuffer gb = rasterize(clip, tris, {8, 8});
  const Tensor attr = Tensor::ones({6, 3}, DType::Float64);
  const Tensor image = Tensor::ones({8, 8, 3}, DType::Float64);
  CHECK_NOTHROW(interpolate(attr, clip.copy(), gb, tris.copy()));
  CHECK_NOTHROW(antialias(image, gb, clip.copy(), tris.copy()));
  Tensor moved = clip.copy();
  moved.data<double>()[5] += 1e-9;
  CHECK_THROWS_AS(interpolate(attr, moved, gb, tris), ValueError);
  CHECK_THROWS_WITH(interpolate(attr, moved, gb, tris),
                    Catch::Contains("'clip'") && Catch::Contains("not the clip the G-buffer was rasterized from"));
  CHECK_THROWS_WITH(antialias(image, gb, moved, tris), Catch::Contains("antialias: argument 'clip'"));
  const Tensor swapped = Tensor::from_vector<std::int32_t>({3, 4, 5, 0, 1, 2}, {2, 3});
  CHECK_THROWS_WITH(interpolate(attr, clip, gb, swapped), Catch::Contains("'triangles'"));
  CHECK_THROWS_WITH(antialias(image, gb, clip, swapped), Catch::Contains("'triangles'"));
  CHECK_THROWS_WITH(interpolate_with_derivatives(attr, moved, gb, tris), Catch::Contains("'clip'"));
  // A G-buffer that records no clip (made by hand, or cleared to evaluate an
  // op at a fixed coverage) is read with whatever clip is given; the
  // three-argument form then has no clip to take.
  GBuffer fixed = gb;
  fixed.clip = Tensor();
  CHECK_NOTHROW(interpolate(attr, moved, fixed, tris));
  CHECK_THROWS_WITH(interpolate(attr, fixed, tris), Catch::Contains("does not record the clip positions"));
}
