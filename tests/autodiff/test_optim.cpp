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

TEST_CASE("Adam: each parameter group steps with its own learning rate", "[autodiff][optim]") {
  Tensor a = Tensor::from_values({1.0}, {1}, DType::Float64).set_requires_grad();
  Tensor b = Tensor::from_values({1.0}, {1}, DType::Float64).set_requires_grad();
  Adam adam({{{a}, AdamOptions{0.1}}, {{b}, AdamOptions{0.01}}});
  REQUIRE(adam.num_groups() == 2);
  backward(sum(a * a) + sum(b * b));
  adam.step();  // the first step moves every element by lr * g / (|g| + eps)
  CHECK(a.at({0}) == Approx(1.0 - 0.1 * 2 / (2 + 1e-8)).epsilon(1e-14));
  CHECK(b.at({0}) == Approx(1.0 - 0.01 * 2 / (2 + 1e-8)).epsilon(1e-14));
  adam.set_lr(1, 0.5);
  CHECK(adam.lr(0) == 0.1);
  CHECK(adam.lr(1) == 0.5);
  adam.set_lr(0.2);
  CHECK(adam.lr(0) == 0.2);
  CHECK(adam.lr(1) == 0.2);
}

TEST_CASE("Adam: one optimizer with groups updates bit for bit like one optimizer per group", "[autodiff][optim]") {
  auto make = [] {
    return std::vector<Tensor>{Tensor::uniform({5, 3}, -1, 1, 1).set_requires_grad(),
                               Tensor::uniform({7}, -1, 1, 2, DType::Float64).set_requires_grad()};
  };
  std::vector<Tensor> x = make(), y = make();
  const AdamOptions first{0.03, 0.8, 0.99, 1e-6}, second{0.002};
  Adam grouped({{{x[0]}, first}, {{x[1]}, second}});
  Adam one({y[0]}, first), two({y[1]}, second);
  auto backward_both = [](const std::vector<Tensor>& p) {
    backward(sum(pow(p[0], 3.0)));
    backward(sum(sin(p[1])));
  };
  for (int step = 0; step < 5; ++step) {
    const double decay = std::pow(0.5, step);
    grouped.set_lr(0, first.lr * decay);
    one.set_lr(first.lr * decay);
    backward_both(x);
    backward_both(y);
    grouped.step();
    one.step();
    two.step();
    grouped.zero_grad();
    one.zero_grad();
    two.zero_grad();
  }
  for (int i = 0; i < 2; ++i) CHECK(x[i].to_vector() == y[i].to_vector());
}

TEST_CASE("Adam: a parameter in two places, a missing group and a bad learning rate are errors",
          "[autodiff][optim][errors]") {
  Tensor p = Tensor::ones({2}).set_requires_grad();
  Tensor q = Tensor::ones({2}).set_requires_grad();
  CHECK_THROWS_AS(Adam({{{p}, {}}, {{q, p}, {}}}), ValueError);
  CHECK_THROWS_AS(Adam({p, p}), ValueError);
  CHECK_THROWS_AS(Adam({{{p}, AdamOptions{0.1, 1.0}}}), ValueError);
  Adam adam({{{p}, {}}, {{q}, {}}});
  CHECK_THROWS_AS(adam.set_lr(2, 0.1), IndexError);
  CHECK_THROWS_AS(adam.lr(2), IndexError);
  CHECK_THROWS_AS(adam.set_lr(1, 0.0), ValueError);
  CHECK_THROWS_AS(adam.set_lr(std::nan("")), ValueError);
}
