#include <catch2/catch.hpp>

#include <cmath>

#include "autodiff/optim.h"
#include "ops/ops.h"

using namespace gr;

TEST_CASE("Adam: the first two steps match a hand computation", "[autodiff][optim]") {
  Tensor x = Tensor::from_values({1.0, -2.0}, {2}, DType::Float64).set_requires_grad();
  Adam adam({x}, AdamOptions{0.1, 0.9, 0.999, 1e-8});
  // L = sum(x^2) -> g = 2x. Step 1: m = 0.1 g, v = 0.001 g^2, mhat = g, vhat = g^2,
  // so x -= 0.1 * g / (|g| + 1e-8).
  backward(sum(x * x));
  adam.step();
  CHECK(x.at({0}) == Approx(1.0 - 0.1 * 2.0 / (2.0 + 1e-8)).epsilon(1e-14));
  CHECK(x.at({1}) == Approx(-2.0 + 0.1 * 4.0 / (4.0 + 1e-8)).epsilon(1e-14));
  // Step 2 by hand for element 0.
  const double g1 = 2.0, x1 = x.at({0}), g2 = 2 * x1;
  const double m = 0.9 * 0.1 * g1 + 0.1 * g2, v = 0.999 * 0.001 * g1 * g1 + 0.001 * g2 * g2;
  const double expected = x1 - 0.1 * (m / (1 - 0.81)) / (std::sqrt(v / (1 - 0.999 * 0.999)) + 1e-8);
  adam.zero_grad();
  backward(sum(x * x));
  adam.step();
  CHECK(x.at({0}) == Approx(expected).epsilon(1e-14));
}

TEST_CASE("Adam: converges on a known quadratic", "[autodiff][optim]") {
  Tensor target = Tensor::from_values({3, -1, 0.5, 2}, {4});
  Tensor x = Tensor::zeros({4}).set_requires_grad();
  Adam adam({x}, AdamOptions{0.05});
  for (int i = 0; i < 600; ++i) {
    adam.zero_grad();
    backward(sum(pow(x - target, 2.0) * Tensor::from_values({1, 10, 0.1, 1}, {4})));
    adam.step();
  }
  for (int i = 0; i < 4; ++i) CHECK(x.at({i}) == Approx(target.at({i})).margin(1e-2));
}

TEST_CASE("Adam: rejects parameters that are not grad-requiring leaves", "[autodiff][optim][errors]") {
  CHECK_THROWS_AS(Adam({Tensor::ones({2})}), ValueError);
  CHECK_THROWS_AS(Adam({Tensor::ones({2}).set_requires_grad()}, AdamOptions{-1}), ValueError);
}
