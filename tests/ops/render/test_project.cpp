#include <catch2/catch.hpp>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

TEST_CASE("wdivide op: gradient matches finite differences", "[ops][project][gradcheck]") {
  Tensor clip = random_input({6, 4}, -1, 1, 31);
  double* d = clip.data<double>();
  for (int i = 0; i < 6; ++i) d[i * 4 + 3] = 0.5 + i * 0.3;  // w away from 0
  require_gradcheck("wdivide", [](const Inputs& in) { return wdivide(in[0]); }, {clip});
}

TEST_CASE("viewport op: gradient matches finite differences and maps NDC corners to image corners", "[ops][project][gradcheck]") {
  Tensor ndc = random_input({5, 3}, -1, 1, 32);
  require_gradcheck("viewport", [](const Inputs& in) { return viewport(in[0], 64, 48); }, {ndc});
  Tensor corners = Tensor::from_values({-1, 1, 0, 1, -1, 0}, {2, 3});
  CHECK(viewport(corners, 64, 48).to_vector() == std::vector<double>{0, 0, 64, 48});
}

TEST_CASE("wdivide and viewport op: bad shapes, w = 0 and bad sizes throw", "[ops][project][errors]") {
  CHECK_THROWS_AS(wdivide(Tensor::ones({3, 3})), ShapeError);
  CHECK_THROWS_WITH(wdivide(Tensor::ones({3, 3})), Catch::Contains("clip") && Catch::Contains("[N, 4]"));
  CHECK_THROWS_AS(wdivide(Tensor::zeros({1, 4})), ValueError);
  CHECK_THROWS_AS(viewport(Tensor::ones({2, 3}), 0, 10), ValueError);
  CHECK_THROWS_AS(viewport(Tensor::ones({2, 2}), 10, 10), ShapeError);
}
