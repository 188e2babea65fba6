#include <catch2/catch.hpp>

#include <cmath>

#include "ops/ops.h"
#include "ops/clip_scenes.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;
using gr::testing::two_triangles;
using gr::testing::two_triangles_clip;

TEST_CASE("rasterize op: G-buffer holds 1-based ids, barycentrics and depth of the nearest triangle", "[ops][rasterize]") {
  Tensor clip = two_triangles_clip();
  GBuffer gb = rasterize(clip, two_triangles(), {32, 32});
  CHECK(gb.tri_id.shape() == Shape{32, 32});
  CHECK(gb.uv.shape() == Shape{32, 32, 2});
  CHECK(gb.depth.shape() == Shape{32, 32});
  CHECK(gb.tri_id.at({0, 0}) == 0);                      // top-left corner: background
  CHECK(gb.depth.at({0, 0}) == raster::kBackgroundDepth);
  int seen[3] = {0, 0, 0};
  for (double id : gb.tri_id.to_vector()) seen[int(id)]++;
  CHECK(seen[1] > 0);
  CHECK(seen[2] > 0);
  // Triangle 2 (id 2) is nearer (smaller z_ndc) where both overlap.
  for (std::int64_t j = 0; j < 32; ++j)
    for (std::int64_t i = 0; i < 32; ++i) {
      if (gb.tri_id.at({j, i}) == 0) continue;
      const double u = gb.uv.at({j, i, 0}), v = gb.uv.at({j, i, 1});
      CHECK((u >= -1e-12 && v >= -1e-12 && u + v <= 1 + 1e-12));
    }
}

TEST_CASE("rasterize op: gradient of barycentrics and depth matches finite differences", "[ops][rasterize][gradcheck]") {
  Tensor clip = two_triangles_clip().set_requires_grad();
  Tensor tris = two_triangles();
  // Coverage stays fixed for steps of 2 eps = 2e-4 (no pixel centre that close to an edge);
  // a large step keeps the finite-difference rounding noise (~1e-16 / eps) small.
  require_gradcheck("rasterize uv", [&](const Inputs& in) { return rasterize(in[0], tris, {24, 20}).uv; }, {clip},
                    GradcheckOptions{1e-4});
  require_gradcheck("rasterize depth", [&](const Inputs& in) { return rasterize(in[0], tris, {24, 20}).depth; }, {clip},
                    GradcheckOptions{1e-4});
}

TEST_CASE("rasterize op: bad inputs throw with messages naming the argument", "[ops][rasterize][errors]") {
  Tensor clip = two_triangles_clip();
  Tensor tris = two_triangles();
  CHECK_THROWS_AS(rasterize(clip, tris, {0, 10}), ValueError);
  CHECK_THROWS_AS(rasterize(clip, tris, {100000, 100000}), ValueError);
  CHECK_THROWS_AS(rasterize(clip, tris, {20000, 1}), ValueError);
  CHECK_THROWS_AS(rasterize(clip, tris, {16, -1}), ValueError);
  CHECK_THROWS_WITH(rasterize(clip, tris, {0, 16}), Catch::Contains("image size 0 x 16"));
  CHECK_THROWS_AS(rasterize(Tensor::ones({6, 3}, DType::Float64), tris, {8, 8}), ShapeError);
  CHECK_THROWS_AS(rasterize(clip, cast(tris, DType::Float32), {8, 8}), DTypeError);
  CHECK_THROWS_WITH(rasterize(clip, Tensor::from_vector<std::int32_t>({0, 1, 6}, {1, 3}), {8, 8}),
                    Catch::Contains("tris[0][2] = 6"));
  CHECK_THROWS_AS(rasterize(clip, Tensor::from_vector<std::int32_t>({0, -1, 2}, {1, 3}), {8, 8}), IndexError);
  Tensor bad = clip.copy();
  bad.data<double>()[5] = std::nan("");
  CHECK_THROWS_AS(rasterize(bad, tris, {8, 8}), ValueError);
  CHECK_THROWS_WITH(rasterize(bad, tris, {8, 8}), Catch::Contains("clip[5]"));
  bad.data<double>()[5] = INFINITY;
  CHECK_THROWS_AS(rasterize(bad, tris, {8, 8}), ValueError);
}

TEST_CASE("rasterize op: a triangle crossing w = 0 renders its visible part with finite gradients", "[ops][rasterize][near]") {
  // Vertex 2 is behind the camera (w < 0).
  Tensor clip = Tensor::from_values({-0.5, -0.5, 0.0, 1.0,  //
                                     0.5, -0.5, 0.0, 1.0,   //
                                     0.0, 0.5, -2.0, -0.5},
                                    {3, 4}, DType::Float64)
                    .set_requires_grad();
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  GBuffer gb = rasterize(clip, tris, {32, 32});
  CHECK(gb.stats.clipped_near == 1);
  double covered = sum(cast(greater(cast(gb.tri_id, DType::Float64), Tensor::scalar(0, DType::Float64)), DType::Float64)).item();
  CHECK(covered > 0);
  Tensor colour = interpolate(Tensor::from_values({1, 0, 0, 0, 1, 0, 0, 0, 1}, {3, 3}, DType::Float64), gb, tris);
  CHECK(all_finite(colour));
  backward(sum(colour * colour) + sum(gb.depth));
  CHECK(all_finite(clip.grad()));
  // Entirely behind the camera: nothing drawn.
  Tensor behind = Tensor::from_values({-0.5, -0.5, 0.0, -1.0, 0.5, -0.5, 0.0, -1.0, 0.0, 0.5, 0.0, -1.0}, {3, 4},
                                      DType::Float64);
  GBuffer none = rasterize(behind, tris, {16, 16});
  CHECK(sum(cast(none.tri_id, DType::Float64)).item() == 0);
}
