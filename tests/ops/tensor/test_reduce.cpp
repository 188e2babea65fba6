#include <catch2/catch.hpp>

#include <utility>
#include <vector>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

TEST_CASE("sum and mean: forward values over all elements and along an axis", "[ops][reduce]") {
  Tensor a = Tensor::from_values({1, 2, 3, 4, 5, 6}, {2, 3});
  CHECK(sum(a).item() == 21);
  CHECK(mean(a).item() == 3.5);
  CHECK(sum(a, 0).to_vector() == std::vector<double>{5, 7, 9});
  CHECK(sum(a, -1).to_vector() == std::vector<double>{6, 15});
  CHECK(sum(a, 1, true).shape() == Shape{2, 1});
  CHECK(mean(a, 0).to_vector() == std::vector<double>{2.5, 3.5, 4.5});
  CHECK(sum(Tensor::zeros({0})).item() == 0);
}

TEST_CASE("sum and mean: gradients match finite differences", "[ops][reduce][gradcheck]") {
  Tensor a = random_input({3, 4, 2}, -1, 1, 21);
  require_gradcheck("sum all", [](const Inputs& in) { return sum(in[0]); }, {a});
  require_gradcheck("sum axis", [](const Inputs& in) { return sum(in[0], 1); }, {a});
  require_gradcheck("sum axis keepdim", [](const Inputs& in) { return sum(in[0], -1, true); }, {a});
  require_gradcheck("mean all", [](const Inputs& in) { return mean(in[0]); }, {a});
  require_gradcheck("mean axis", [](const Inputs& in) { return mean(in[0], 0); }, {a});
}

TEST_CASE("sum_to_shape and broadcast_to: gradients match finite differences", "[ops][reduce][gradcheck]") {
  Tensor a = random_input({4, 3}, -1, 1, 22);
  Tensor b = random_input({3}, -1, 1, 23);
  require_gradcheck("sum_to_shape", [](const Inputs& in) { return sum_to_shape(in[0], Shape{3}); }, {a});
  require_gradcheck("broadcast_to", [](const Inputs& in) { return broadcast_to(in[0], Shape{2, 3}); }, {b});
  CHECK(sum_to_shape(Tensor::ones({4, 3}), Shape{4, 1}).to_vector() == std::vector<double>{3, 3, 3, 3});
  CHECK_THROWS_AS(sum_to_shape(Tensor::ones({4, 3}), Shape{2}), ShapeError);
  CHECK_THROWS_AS(broadcast_to(Tensor::ones({2}), Shape{3}), ShapeError);
}

TEST_CASE("sum: large float32 reductions are bit-identical for 1 and 2 threads", "[ops][reduce][determinism]") {
  Tensor a = Tensor::uniform({1 << 20}, -1, 1, 24);
  Tensor b = Tensor::uniform({4096, 3}, -1, 1, 25);
  set_num_threads(1);
  const double s1 = sum(a).item();
  const auto c1 = sum(b, 0).to_vector();
  set_num_threads(2);
  const double s2 = sum(a).item();
  const auto c2 = sum(b, 0).to_vector();
  set_num_threads(0);
  CHECK(s1 == s2);
  CHECK(c1 == c2);
}

TEST_CASE("reductions: bad axes and empty means throw", "[ops][reduce][errors]") {
  Tensor a = Tensor::ones({2, 3});
  CHECK_THROWS_AS(sum(a, 2), IndexError);
  CHECK_THROWS_AS(mean(Tensor::zeros({0})), ShapeError);
  CHECK_THROWS_AS(sum(Tensor::ones({2}, DType::Int32)), DTypeError);
}

TEST_CASE("sum over an empty axis gives zeros and broadcasting to an empty shape does no work", "[ops][reduce]") {
  // Found by fuzz_shapes: the reduction divided by the empty axis' extent, and
  // broadcast_to walked every empty row of [2^31 - 1, 4096, 0].
  const Tensor s = sum(Tensor::zeros({5, 0}), 1);
  REQUIRE(s.shape() == Shape({5}));
  for (double v : s.to_vector()) CHECK(v == 0.0);
  CHECK(sum(Tensor::zeros({1 << 20, 0}), -1).numel() == 1 << 20);
  CHECK(broadcast_to(Tensor::zeros({0}), Shape({(std::int64_t(1) << 31) - 1, 4096, 0})).numel() == 0);
}

TEST_CASE("sum_of_products: its value is the sum of the pairs' products and its gradients are the weights' bits, "
          "as the sum-of-products composite's",
          "[ops][reduce]") {
  for (DType dtype : {DType::Float32, DType::Float64}) {
    INFO(dtype_name(dtype));
    const Tensor a = Tensor::uniform({40, 3}, -1, 1, 31, dtype), b = Tensor::uniform({7}, -2, 2, 32, dtype);
    const Tensor wa = Tensor::uniform({40, 3}, -1, 1, 33, dtype), wb = Tensor::uniform({7}, -1, 1, 34, dtype);
    double want = 0;
    for (const auto& [x, w] : {std::pair<Tensor, Tensor>{a, wa}, std::pair<Tensor, Tensor>{b, wb}}) {
      const std::vector<double> xv = x.to_vector(), wv = w.to_vector();
      for (std::size_t i = 0; i < xv.size(); ++i) want += xv[i] * wv[i];
    }
    CHECK(sum_of_products({a, b}, {wa, wb}).item() == Approx(want).epsilon(dtype == DType::Float32 ? 1e-6 : 1e-14));
    CHECK(sum_of_products({a, b}, {wa, wb}).dtype() == dtype);
    // Gradients with an upstream of 1 and of 3 (times the weights).
    for (double upstream : {1.0, 3.0}) {
      INFO("upstream " << upstream);
      auto gradients = [&](bool composite) {
        const Tensor x = a.copy().set_requires_grad(), y = b.copy().set_requires_grad();
        backward(upstream * (composite ? sum(x * wa) + sum(y * wb) : sum_of_products({x, y}, {wa, wb})));
        return std::pair<Tensor, Tensor>{x.grad(), y.grad()};
      };
      const auto got = gradients(false), want_grads = gradients(true);
      CHECK(gr::testing::same_bits(got.first, want_grads.first));
      CHECK(gr::testing::same_bits(got.second, want_grads.second));
    }
  }
  // An empty pair adds nothing.
  const Tensor empty = Tensor::zeros({0, 3}), two = Tensor::ones({2});
  CHECK(sum_of_products({empty, two}, {empty, two}).item() == 2);
}

TEST_CASE("sum_of_products: gradients match float64 finite differences, also for zeros, mixed magnitudes and a "
          "value repeated in two pairs",
          "[ops][reduce][gradcheck]") {
  const Tensor w0 = Tensor::uniform({5, 4}, -1, 1, 41, DType::Float64);
  const Tensor w1 = Tensor::uniform({6}, -1, 1, 42, DType::Float64);
  require_gradcheck("sum_of_products", [&](const Inputs& in) { return sum_of_products(in, {w0, w1}); },
                    {random_input({5, 4}, -1, 1, 43), random_input({6}, -1, 1, 44)});
  // Hard: zero and huge weights, a zero value, and one value in two pairs (its gradient is the weights' sum).
  const Tensor hard_w = Tensor::from_values({0.0, 1e6, -1e-6, 0.0}, {4}, DType::Float64);
  const Tensor other_w = Tensor::from_values({2.0, -3.0, 0.5, 1e3}, {4}, DType::Float64);
  // Linear: a large step has no truncation error and keeps the rounding of the 1e6 terms small.
  GradcheckOptions options;
  options.eps = 1e-2;
  require_gradcheck("sum_of_products hard",
                    [&](const Inputs& in) { return sum_of_products({in[0], in[0], in[1]}, {hard_w, other_w, hard_w}); },
                    {random_input({4}, -1, 1, 45), Tensor::zeros({4}, DType::Float64).set_requires_grad()}, options);
}

TEST_CASE("sum_of_products: the value is bit-identical for 1, 2 and 8 threads", "[ops][reduce][determinism]") {
  const Tensor a = Tensor::uniform({100003}, -1, 1, 51), w = Tensor::uniform({100003}, -1, 1, 52);
  set_num_threads(1);
  const double one = sum_of_products({a}, {w}).item();
  for (int threads : {2, 8}) {
    set_num_threads(threads);
    CHECK(sum_of_products({a}, {w}).item() == one);
  }
  set_num_threads(0);
}

TEST_CASE("sum_of_products: rejects missing, mismatched or differentiable weights, naming the argument",
          "[ops][reduce][errors]") {
  const Tensor a = Tensor::zeros({3, 2}), w = Tensor::ones({3, 2});
  CHECK_THROWS_WITH(sum_of_products({}, {}), Catch::Contains("argument 'values' must hold at least one tensor"));
  CHECK_THROWS_WITH(sum_of_products({a}, {w, w}), Catch::Contains("argument 'weights' must hold one tensor per value"));
  CHECK_THROWS_WITH(sum_of_products({a}, {Tensor::ones({2, 3})}), Catch::Contains("weights[0]"));
  CHECK_THROWS_WITH(sum_of_products({a}, {Tensor::ones({3, 2}, DType::Float64)}), Catch::Contains("weights[0]"));
  CHECK_THROWS_WITH(sum_of_products({a}, {Tensor()}), Catch::Contains("weights[0]"));
  CHECK_THROWS_WITH(sum_of_products({a, Tensor::zeros({2}, DType::Float64)}, {w, Tensor::ones({2}, DType::Float64)}),
                    Catch::Contains("values[1]"));
  CHECK_THROWS_WITH(sum_of_products({Tensor::zeros({2}, DType::Int32)}, {Tensor::zeros({2}, DType::Int32)}),
                    Catch::Contains("values[0]"));
  const Tensor x = a.copy().set_requires_grad(), v = w.copy().set_requires_grad();
  CHECK_THROWS_WITH(sum_of_products({x}, {v}), Catch::Contains("'weights[0]' requires a gradient"));
  NoGradGuard no_grad;  // nothing recorded: any weight will do
  CHECK(sum_of_products({x}, {v}).item() == 0);
}
