// The grad() contract (autodiff/base/tensor.h): a leaf has a gradient after
// backward() exactly when the loss depends on it through recorded ops, zeros
// where the derivative vanishes, whichever op it met.
#include <catch2/catch.hpp>

#include "ops/ops.h"

using namespace gr;

namespace {

bool all_zero(const Tensor& t) {
  for (double x : t.to_vector())
    if (x != 0) return false;
  return true;
}

// One triangle well off screen: nothing is covered.
Tensor offscreen_clip() {
  return Tensor::from_values({5, 5, 0, 1, 6, 5, 0, 1, 5, 6, 0, 1}, {3, 4}, DType::Float64).set_requires_grad();
}

}  // namespace

TEST_CASE("grad contract: a leaf the loss does not depend on has no gradient, one it depends on has zeros at a flat "
          "spot",
          "[autodiff][grad]") {
  Tensor used = Tensor::from_values({5.0, -5.0}, {2}, DType::Float64).set_requires_grad();
  Tensor unused = Tensor::ones({2}, DType::Float64).set_requires_grad();
  Tensor masked = Tensor::ones({2}, DType::Float64).set_requires_grad();
  Tensor untracked = Tensor::ones({2}, DType::Float64).set_requires_grad();
  Tensor side;
  {
    NoGradGuard no_grad;
    side = untracked * 2.0;
  }
  CHECK_FALSE(used.has_grad());
  backward(sum(clamp(used, -1, 1) * (masked > 0.0) + side));
  REQUIRE(used.has_grad());
  CHECK(all_zero(used.grad()));  // both elements clamped: derivative 0
  CHECK_FALSE(unused.has_grad());
  CHECK_FALSE(masked.has_grad());    // only seen through a comparison mask
  CHECK_FALSE(untracked.has_grad());  // only seen under NoGradGuard
  CHECK_FALSE(unused.grad().defined());
  used.zero_grad();
  CHECK_FALSE(used.has_grad());
}

TEST_CASE("grad contract: ops whose derivative vanishes still give every input they read a zero gradient",
          "[autodiff][grad]") {
  SECTION("a nearest-filter texture gives its uv zeros") {
    Tensor tex = Tensor::uniform({4, 4, 3}, 0, 1, 1, DType::Float64);
    Tensor uv = Tensor::uniform({5, 2}, 0, 1, 2, DType::Float64).set_requires_grad();
    backward(sum(texture(tex, uv, TextureOptions{Filter::Nearest})));
    REQUIRE(uv.has_grad());
    CHECK(all_zero(uv.grad()));
  }
  SECTION("the same through an op in between") {
    Tensor tex = Tensor::uniform({4, 4, 3}, 0, 1, 1, DType::Float64);
    Tensor uv = Tensor::uniform({5, 2}, 0, 1, 2, DType::Float64).set_requires_grad();
    backward(sum(texture(tex, uv * 0.5, TextureOptions{Filter::Nearest})));
    REQUIRE(uv.has_grad());
    CHECK(all_zero(uv.grad()));
  }
  SECTION("rasterize, interpolate and antialias with nothing on screen") {
    Tensor clip = offscreen_clip();
    Tensor colours = Tensor::ones({3, 3}, DType::Float64).set_requires_grad();
    const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
    const GBuffer gb = rasterize(clip, tris, {8, 8});
    const Tensor image = interpolate(colours, gb, tris);
    backward(sum(antialias(image, gb, clip, tris)) + sum(gb.depth));
    REQUIRE(clip.has_grad());
    REQUIRE(colours.has_grad());
    CHECK(all_zero(clip.grad()));
    CHECK(all_zero(colours.grad()));
  }
}
