// Batched rasterize / interpolate / antialias (ops/render/batch.h): every image equals
// a separate call bit for bit (values and gradients), for 1, 2 and 8 threads;
// range mode numbers triangles globally; gradients match finite differences;
// bad batches are errors naming the argument.
#include <catch2/catch.hpp>

#include <cmath>

#include "ops/clip_scenes.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

constexpr int W = 24, H = 20, B = 3;

RasterizeOptions size() { return {W, H}; }

// B copies of the two-triangle scene, image b moved b pixels to the right
// (whole pixels keep the scene's pixel centres away from its edges).
Tensor batch_clip() {
  std::vector<double> v;
  const std::vector<double> base = testing::two_triangles_clip().to_vector();
  for (int b = 0; b < B; ++b)
    for (std::size_t i = 0; i < base.size(); ++i)
      v.push_back(base[i] + (i % 4 == 0 ? 2.0 * b / W * base[i + 3] : 0.0));
  return Tensor::from_values(v, {B, 6, 4}, DType::Float64);
}

std::vector<double> concat_values(const std::vector<Tensor>& ts) {
  std::vector<double> out;
  for (const Tensor& t : ts)
    for (double x : t.to_vector()) out.push_back(x);
  return out;
}

// Values and gradients of the whole chain, batched or one image at a time.
std::vector<double> run_chain(bool batched) {
  const Tensor tris = testing::two_triangles();
  Tensor clip = batch_clip().set_requires_grad();
  Tensor attr = random_input({B, 6, 3}, 0, 1, 5);
  std::vector<double> result;
  if (batched) {
    const GBuffer g = rasterize_batch(clip, tris, size());
    const Tensor img = antialias_batch(interpolate_batch(attr, g, tris), g, clip, tris);
    backward(sum(mul(img, img)));
    result = concat_values({img});
  } else {
    std::vector<Tensor> images;
    Tensor loss = Tensor::scalar(0.0, DType::Float64);
    for (int b = 0; b < B; ++b) {
      const Tensor c = reshape(slice(clip, 0, b, b + 1), {6, 4}), a = reshape(slice(attr, 0, b, b + 1), {6, 3});
      const GBuffer g = rasterize(c, tris, size());
      const Tensor img = antialias(interpolate(a, g, tris), g, c, tris);
      images.push_back(img);
      loss = add(loss, sum(mul(img, img)));
    }
    backward(loss);
    result = concat_values(images);
  }
  for (double x : concat_values({clip.grad(), attr.grad()})) result.push_back(x);
  return result;
}

}  // namespace

TEST_CASE("batch: instanced images and their gradients equal separate calls bit for bit, for 1, 2 and 8 threads",
          "[batch][parallel]") {
  const std::vector<double> separate = run_chain(false);
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    CHECK(run_chain(true) == separate);
  }
  set_num_threads(0);
}

TEST_CASE("batch: range mode draws each image's range and numbers triangles in the whole list", "[batch]") {
  const Tensor clip = testing::two_triangles_clip(), tris = testing::two_triangles();
  const Tensor ranges = Tensor::from_vector<std::int32_t>({0, 1, 1, 1, 0, 2, 2, 0}, {4, 2});
  const GBuffer g = rasterize_ranges(clip, tris, ranges, size());
  REQUIRE(g.tri_id.shape() == Shape{4, H, W});
  const std::vector<double> ids = g.tri_id.to_vector();
  const std::int32_t firsts[4] = {0, 1, 0, 2}, counts[4] = {1, 1, 2, 0};
  for (int b = 0; b < 4; ++b) {
    const Tensor sub = slice(tris, 0, firsts[b], firsts[b] + counts[b]);
    const GBuffer alone = rasterize(clip, sub, size());
    const std::vector<double> a = alone.tri_id.to_vector();
    for (int q = 0; q < W * H; ++q) REQUIRE(ids[b * W * H + q] == (a[q] ? a[q] + firsts[b] : 0.0));
  }
  // Interpolation with shared positions and attributes reads the global ids.
  const Tensor attr = random_input({6, 2}, 0, 1, 9);
  const Tensor out = interpolate_batch(attr, g, tris);
  const Tensor both = interpolate(attr, rasterize(clip, tris, size()), tris);
  const std::vector<double> o = out.to_vector(), e = both.to_vector();
  for (int i = 0; i < W * H * 2; ++i) CHECK(o[2 * W * H * 2 + i] == e[i]);
}

TEST_CASE("batch: gradients of positions and shared attributes through the batched chain match finite differences",
          "[batch][gradcheck]") {
  const Tensor tris = testing::two_triangles();
  SECTION("instanced") {
    const Tensor clip = batch_clip().set_requires_grad();
    const Tensor attr = random_input({6, 2}, 0, 1, 11);
    require_gradcheck("batch instanced chain",
                      [&](const Inputs& in) {
                        const GBuffer g = rasterize_batch(in[0], tris, size());
                        return antialias_batch(interpolate_batch(in[1], g, tris), g, in[0], tris);
                      },
                      {clip, attr});
  }
  SECTION("range mode") {
    const Tensor clip = testing::two_triangles_clip().set_requires_grad();
    const Tensor attr = random_input({6, 2}, 0, 1, 12);
    const Tensor ranges = Tensor::from_vector<std::int32_t>({0, 2, 1, 1}, {2, 2});
    require_gradcheck("batch range chain",
                      [&](const Inputs& in) {
                        const GBuffer g = rasterize_ranges(in[0], tris, ranges, size());
                        return antialias_batch(interpolate_batch(in[1], g, tris), g, in[0], tris);
                      },
                      {clip, attr});
  }
}

TEST_CASE("batch: bad batches are errors naming the argument", "[batch][errors]") {
  const Tensor tris = testing::two_triangles(), clip = batch_clip();
  CHECK_THROWS_WITH(rasterize_batch(testing::two_triangles_clip(), tris, size()),
                    Catch::Contains("'clip' must have shape [B, N, 4]"));
  const Tensor bad_range = Tensor::from_vector<std::int32_t>({1, 2}, {1, 2});
  CHECK_THROWS_WITH(rasterize_ranges(testing::two_triangles_clip(), tris, bad_range, size()),
                    Catch::Contains("ranges[0] = (1, 2) is outside the 2 triangles"));
  const GBuffer g = rasterize_batch(clip, tris, size());
  CHECK_THROWS_WITH(interpolate_batch(Tensor::zeros({2, 6, 3}, DType::Float64), g, tris),
                    Catch::Contains("'attributes' must be [N, C] or [B, N, C] with B = 3"));
  const GBuffer single = rasterize(testing::two_triangles_clip(), tris, size());
  CHECK_THROWS_WITH(interpolate_batch(Tensor::zeros({6, 3}, DType::Float64), single, tris),
                    Catch::Contains("rasterize_batch or rasterize_ranges"));
  CHECK_THROWS_WITH(antialias_batch(Tensor::zeros({B, H, W - 1, 3}, DType::Float64), g, clip, tris),
                    Catch::Contains("differ in size"));
  Tensor moved = clip.copy();
  moved.data<double>()[0] += 0.25;
  const Tensor swapped = Tensor::from_vector<std::int32_t>({3, 4, 5, 0, 1, 2}, {2, 3});
  CHECK_THROWS_WITH(interpolate_batch(Tensor::zeros({6, 3}, DType::Float64), g, swapped),
                    Catch::Contains("interpolate_batch: argument 'triangles' are not the triangles the G-buffer"));
  CHECK_THROWS_WITH(antialias_batch(Tensor::zeros({B, H, W, 3}, DType::Float64), g, moved, tris),
                    Catch::Contains("argument 'clip' is not the clip"));
}
