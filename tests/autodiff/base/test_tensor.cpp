#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "autodiff/base/tensor.h"

using namespace gr;

TEST_CASE("tensor: factories fill shape, dtype and values", "[autodiff][tensor]") {
  Tensor z = Tensor::zeros({2, 3});
  CHECK(z.shape() == Shape{2, 3});
  CHECK(z.dtype() == DType::Float32);
  CHECK(z.numel() == 6);
  CHECK(z.at({1, 2}) == 0.0);
  Tensor f = Tensor::full({4}, 2.5, DType::Float64);
  CHECK(f.to_vector() == std::vector<double>{2.5, 2.5, 2.5, 2.5});
  Tensor s = Tensor::scalar(3.0);
  CHECK(s.rank() == 0);
  CHECK(s.item() == 3.0);
  Tensor v = Tensor::from_vector<std::int32_t>({1, 2, 3, 4, 5, 6}, {3, 2});
  CHECK(v.dtype() == DType::Int32);
  CHECK(v.at({2, 1}) == 6.0);
}

TEST_CASE("tensor: rank above 4, wrong element type and bad indices throw", "[autodiff][tensor][errors]") {
  CHECK_THROWS_AS(Shape({1, 2, 3, 4, 5}), ShapeError);
  Tensor t = Tensor::zeros({2, 2});
  CHECK_THROWS_AS(t.data<double>(), DTypeError);
  CHECK_THROWS_AS(t.at({2, 0}), IndexError);
  CHECK_THROWS_AS(t.item(), ShapeError);
  CHECK_THROWS_AS(Tensor::from_values({1, 2, 3}, {2, 2}), ShapeError);
  Tensor i = Tensor::zeros({3}, DType::Int32);
  CHECK_THROWS_AS(i.set_requires_grad(), DTypeError);
}

TEST_CASE("tensor: detach shares storage without gradient tracking, and copy does not share", "[autodiff][tensor]") {
  Tensor a = Tensor::ones({3}).set_requires_grad();
  Tensor d = a.detach();
  CHECK_FALSE(d.requires_grad());
  d.data<float>()[0] = 7;
  CHECK(a.at({0}) == 7.0);
  Tensor c = a.copy();
  c.data<float>()[1] = 9;
  CHECK(a.at({1}) == 1.0);
}

TEST_CASE("tensor: uniform is reproducible from its seed", "[autodiff][tensor]") {
  Tensor a = Tensor::uniform({100}, -1, 1, 42, DType::Float64);
  Tensor b = Tensor::uniform({100}, -1, 1, 42, DType::Float64);
  CHECK(a.to_vector() == b.to_vector());
  for (double x : a.to_vector()) CHECK((x >= -1 && x < 1));
}

TEST_CASE("tensor: uniform refuses an empty or non-finite range", "[autodiff][tensor][errors]") {
  CHECK_THROWS_AS(Tensor::uniform({4}, 1, 0, 1), ValueError);
  CHECK_THROWS_WITH(Tensor::uniform({4}, 1, 0, 1), Catch::Contains("Tensor::uniform") && Catch::Contains("lo <= hi"));
  const double inf = std::numeric_limits<double>::infinity(), nan = std::nan("");
  CHECK_THROWS_AS(Tensor::uniform({4}, 0, inf, 1), ValueError);
  CHECK_THROWS_AS(Tensor::uniform({4}, nan, 1, 1), ValueError);
  CHECK_THROWS_AS(Tensor::uniform({4}, -1e308, 1e308, 1), ValueError);  // hi - lo overflows
  for (double x : Tensor::uniform({3}, 2, 2, 1).to_vector()) CHECK(x == 2.0);  // lo == hi: a constant
}

TEST_CASE("tensor: int32 factories refuse values that have no int32", "[autodiff][tensor][errors]") {
  CHECK_THROWS_AS(Tensor::full({2}, std::nan(""), DType::Int32), ValueError);
  CHECK_THROWS_AS(Tensor::scalar(3e9, DType::Int32), ValueError);
  CHECK_THROWS_WITH(Tensor::from_values({1, 2, 1e10}, {3}, DType::Int32), Catch::Contains("index 2"));
  CHECK(Tensor::from_values({-2147483648.0, 2147483647.0, -1.5}, {3}, DType::Int32).to_vector() ==
        std::vector<double>{-2147483648.0, 2147483647.0, -1.0});
}
