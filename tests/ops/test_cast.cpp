// cast to int32 of values that have no int32 (issue 16 item 8); cast's
// gradient checks live with the other elementwise ops.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"

using namespace gr;

TEST_CASE("cast: float to int32 truncates toward zero at the ends of the int32 range", "[ops][cast]") {
  Tensor a = Tensor::from_values({-2147483648.0, 2147483647.9, -2.7, 2.7, -0.0}, {5}, DType::Float64);
  CHECK(cast(a, DType::Int32).to_vector() == std::vector<double>{-2147483648.0, 2147483647.0, -2, 2, 0});
}

TEST_CASE("cast: NaN, Inf and out-of-range floats to int32 are refused with index and value", "[ops][cast][errors]") {
  const double inf = std::numeric_limits<double>::infinity();
  for (DType from : {DType::Float32, DType::Float64}) {
    for (double bad : {std::nan(""), inf, -inf, 2147483648.0, -2147483904.0, 1e20}) {
      Tensor a = cast(Tensor::from_values({1, 2, bad, 4}, {2, 2}, DType::Float64), from);
      CHECK_THROWS_AS(cast(a, DType::Int32), ValueError);
      CHECK_THROWS_WITH(cast(a, DType::Int32), Catch::Contains("cast: a[2]") && Catch::Contains("int32"));
    }
  }
  Tensor nan = Tensor::full({3}, std::nan(""));
  CHECK_THROWS_WITH(cast(nan, DType::Int32), Catch::Contains("nan"));
  CHECK_THROWS_WITH(cast(Tensor::full({2}, 3e9), DType::Int32), Catch::Contains("3000000000"));
}

TEST_CASE("cast: the element refused is the first bad one for any thread count", "[ops][cast][errors]") {
  Tensor a = Tensor::zeros({200000});
  float* d = a.data<float>();
  d[150001] = std::nanf("");
  d[70003] = 1e10f;
  d[199999] = -1e10f;
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    CHECK_THROWS_WITH(cast(a, DType::Int32), Catch::Contains("a[70003]"));
  }
  set_num_threads(0);
}
