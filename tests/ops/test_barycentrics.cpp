// Perspective-correct barycentrics, their screen derivatives and attribute
// derivatives (ops/barycentrics.h): equal to interpolate's perspective
// weights and interpolate_with_derivatives' analytic derivatives, to finite
// differences across pixels, and differentiable w.r.t. clip and attributes.
#include <catch2/catch.hpp>

#include <cmath>

#include "clip_scenes.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

constexpr int W = 24, H = 20;

// One-hot attributes per vertex of each triangle: (b1, b2) after interpolation.
Tensor barycentric_attributes(std::int64_t vertices) {
  std::vector<double> a;
  for (std::int64_t v = 0; v < vertices; ++v) {
    a.push_back(v % 3 == 1);
    a.push_back(v % 3 == 2);
  }
  return Tensor::from_values(a, {vertices, 2}, DType::Float64);
}

double max_difference(const Tensor& a, const Tensor& b) {
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  REQUIRE(x.size() == y.size());
  double worst = 0;
  for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(x[i] - y[i]));
  return worst;
}

}  // namespace

TEST_CASE("barycentrics: perspective-correct weights and derivatives equal interpolate's on a perspective scene",
          "[ops][barycentrics]") {
  const Tensor clip = gr::testing::two_triangles_clip(), tris = gr::testing::two_triangles();
  const GBuffer gb = rasterize(clip, tris, {W, H});
  const PerspectiveBarycentrics pb = perspective_barycentrics(clip, tris, gb);
  const InterpolatedWithDerivatives ref = interpolate_with_derivatives(barycentric_attributes(6), clip, gb, tris);
  CHECK(max_difference(pb.uv, ref.values) < 1e-13);
  // uv_db = (db1/dx, db1/dy, db2/dx, db2/dy); the reference's channels are (b1, b2).
  const Tensor db1 = stack({channel(pb.uv_db, 0), channel(pb.uv_db, 2)}, 2);
  const Tensor db2 = stack({channel(pb.uv_db, 1), channel(pb.uv_db, 3)}, 2);
  CHECK(max_difference(reshape(db1, {H, W, 2}), ref.d_dx) < 1e-13);
  CHECK(max_difference(reshape(db2, {H, W, 2}), ref.d_dy) < 1e-13);
  // Background pixels are zero, covered ones are not all zero.
  const std::vector<double> uv = pb.uv.to_vector();
  const std::vector<double> id = gb.tri_id.to_vector();
  bool any = false;
  for (std::size_t p = 0; p < id.size(); ++p) {
    if (id[p] == 0) CHECK((uv[2 * p] == 0 && uv[2 * p + 1] == 0));
    any = any || uv[2 * p] != 0;
  }
  CHECK(any);
}

TEST_CASE("barycentrics: on an affine triangle the derivatives are the differences between neighbouring pixels",
          "[ops][barycentrics]") {
  // w = 1 everywhere: barycentrics are affine in screen space.
  const Tensor clip = Tensor::from_values({-0.9, -0.8, 0.1, 1, 0.85, -0.7, 0.2, 1, -0.2, 0.9, 0.3, 1}, {3, 4},
                                          DType::Float64);
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  const GBuffer gb = rasterize(clip, tris, {W, H});
  const PerspectiveBarycentrics pb = perspective_barycentrics(clip, tris, gb);
  const std::vector<double> uv = pb.uv.to_vector(), db = pb.uv_db.to_vector(), id = gb.tri_id.to_vector();
  int checked = 0;
  for (int y = 0; y + 1 < H; ++y)
    for (int x = 0; x + 1 < W; ++x) {
      const int p = y * W + x, right = p + 1, below = p + W;
      if (!id[p] || !id[right] || !id[below]) continue;
      for (int k = 0; k < 2; ++k) {
        CHECK(uv[2 * right + k] - uv[2 * p + k] == Approx(db[4 * p + 2 * k]).margin(1e-12));
        CHECK(uv[2 * below + k] - uv[2 * p + k] == Approx(db[4 * p + 2 * k + 1]).margin(1e-12));
      }
      ++checked;
    }
  CHECK(checked > 50);
}

TEST_CASE("barycentrics: weights derivatives and attribute derivatives pass a float64 gradcheck w.r.t. clip and attributes",
          "[ops][barycentrics][gradcheck]") {
  const Tensor tris = gr::testing::two_triangles();
  Tensor clip = gr::testing::two_triangles_clip().copy().set_requires_grad();
  const GBuffer gb = rasterize(clip.detach(), tris, {W, H});  // coverage fixed
  auto all = [&](const Inputs& in) {
    const PerspectiveBarycentrics pb = perspective_barycentrics(in[0], tris, gb);
    return concat({pb.uv, pb.uv_db}, 2);
  };
  require_gradcheck("perspective_barycentrics", all, {clip});
  Tensor attributes = random_input({6, 3}, -1, 1, 3);
  auto derivatives = [&](const Inputs& in) {
    const AttributeDerivatives d = attribute_derivatives(in[1], in[0], tris, gb);
    return concat({d.d_dx, d.d_dy}, 2);
  };
  require_gradcheck("attribute_derivatives", derivatives, {clip, attributes});

  SECTION("hard cases: a vertex close to w = 0 and a sliver") {
    // Vertex 2 at w = 0.02 (just in front of the eye), and a thin sliver.
    Tensor hard = Tensor::from_values({-0.9, -0.8, 0.1, 1.0, 0.9, -0.7, 0.2, 1.2, 0.0, 0.005, 0.001, 0.02,  //
                                       -0.9, 0.5, 0.0, 1.0, 0.9, 0.52, 0.1, 1.0, 0.9, 0.56, 0.1, 1.0},
                                      {6, 4}, DType::Float64)
                      .set_requires_grad();
    const GBuffer hg = rasterize(hard.detach(), tris, {W, H});
    auto f = [&](const Inputs& in) {
      const PerspectiveBarycentrics pb = perspective_barycentrics(in[0], tris, hg);
      return concat({pb.uv, pb.uv_db}, 2);
    };
    GradcheckOptions opt;
    opt.eps = 1e-6;  // w = 0.02: steps must stay small against w
    opt.rtol = 1e-5;
    require_gradcheck("perspective_barycentrics hard", f, {hard}, opt);
    CHECK(gr::testing::all_finite(f({hard})));
  }
}

TEST_CASE("barycentrics: a texture's level of detail is differentiable back to the clip positions",
          "[ops][barycentrics][texture][gradcheck]") {
  const Tensor tris = gr::testing::two_triangles();
  Tensor clip = gr::testing::two_triangles_clip().copy().set_requires_grad();
  const GBuffer gb = rasterize(clip.detach(), tris, {W, H});
  // uv attributes spanning several texels per pixel: LODs inside the chain.
  const Tensor uvs = Tensor::from_values({0.1, 0.2, 3.1, 0.4, 0.7, 2.9, 0.2, 0.1, 2.8, 0.7, 1.1, 3.3}, {6, 2},
                                         DType::Float64);
  const Tensor tex = Tensor::uniform({32, 32, 1}, 0, 1, 5, DType::Float64);
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  auto f = [&](const Inputs& in) {
    const Tensor uv = interpolate(uvs, in[0], gb, tris);
    const AttributeDerivatives d = attribute_derivatives(uvs, in[0], tris, gb);
    return texture(tex, uv, opt, d.d_dx, d.d_dy);
  };
  GradcheckOptions g;
  g.eps = 1e-6;  // small steps: stay inside the bilinear cells and the LOD's level
  require_gradcheck("texture lod through attribute_derivatives", f, {clip}, g);
}

TEST_CASE("barycentrics: bad inputs are refused by name", "[ops][barycentrics][errors]") {
  const Tensor clip = gr::testing::two_triangles_clip(), tris = gr::testing::two_triangles();
  const GBuffer gb = rasterize(clip, tris, {W, H});
  const Tensor other = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  CHECK_THROWS_WITH(perspective_barycentrics(clip, other, gb), Catch::Contains("tri_id"));
  CHECK_THROWS_WITH(attribute_derivatives(Tensor::zeros({5, 2}, DType::Float64), clip, tris, gb),
                    Catch::Contains("attributes"));
  CHECK_THROWS_AS(attribute_derivatives(Tensor::zeros({6, 2}, DType::Float32), clip, tris, gb), DTypeError);
}
