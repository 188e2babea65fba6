#include <catch2/catch.hpp>

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
