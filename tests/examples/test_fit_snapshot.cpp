// Tests of examples/fit/snapshot.h: the strip's layout, against the tensor ops
// that compose it (target | current | clamp(|current - target| x gain), white
// gutters), bit for bit; and a clear error for mismatched images.
#include <catch2/catch.hpp>

#include <random>

#include "autodiff/base/error.h"
#include "examples/fit/snapshot.h"
#include "ops/ops.h"

using namespace gr;

namespace {

Tensor random_image(std::int64_t h, std::int64_t w, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> value(-0.2f, 1.2f);  // some outside [0, 1]: the strip keeps them
  std::vector<float> v(static_cast<std::size_t>(h * w * 3));
  for (float& x : v) x = value(rng);
  return Tensor::from_vector(v, {h, w, 3});
}

// The strip composed with tensor ops (what snapshot_strip computes in one pass).
Tensor strip_from_ops(const std::vector<Tensor>& targets, const std::vector<Tensor>& currents) {
  const std::int64_t h = targets[0].size(0), w = targets[0].size(1);
  const Tensor vertical = Tensor::ones({h, 2, 3}), horizontal = Tensor::ones({2, 3 * w + 4, 3});
  std::vector<Tensor> rows;
  for (std::size_t v = 0; v < targets.size(); ++v) {
    const Tensor difference = clamp(abs(currents[v] - targets[v]) * fit::kDifferenceGain, 0.0, 1.0);
    if (v > 0) rows.push_back(horizontal);
    rows.push_back(concat({targets[v], vertical, currents[v], vertical, difference}, 1));
  }
  return concat(rows, 0);
}

}  // namespace

TEST_CASE("fit snapshot: the strip is target | current | scaled difference per view, with white gutters",
          "[examples][fit]") {
  for (int views : {1, 3}) {
    std::vector<Tensor> targets, currents;
    for (int v = 0; v < views; ++v) {
      targets.push_back(random_image(5, 7, 2 * v + 1));
      currents.push_back(random_image(5, 7, 2 * v + 2));
    }
    const Tensor strip = fit::snapshot_strip(targets, currents);
    REQUIRE(strip.shape() == Shape{views * 5 + (views - 1) * 2, 3 * 7 + 4, 3});
    CHECK(strip.to_vector() == strip_from_ops(targets, currents).to_vector());
  }
}

TEST_CASE("fit snapshot: images of another size or channel count are refused, naming the image",
          "[examples][fit]") {
  const Tensor a = random_image(4, 4, 1), b = random_image(4, 5, 2);
  CHECK_THROWS_AS(fit::snapshot_strip({a, a}, {a, b}), ShapeError);
  CHECK_THROWS_WITH(fit::snapshot_strip({a}, {Tensor::zeros({4, 4, 4})}), Catch::Contains("float32[4, 4, 4]"));
  CHECK_THROWS_AS(fit::snapshot_strip({a}, {}), ValueError);
}
