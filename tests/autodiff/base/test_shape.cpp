#include <catch2/catch.hpp>

#include "ops/ops.h"

using namespace gr;

namespace {
constexpr std::int64_t k2p31 = std::int64_t(1) << 31;
constexpr std::int64_t k2p62 = std::int64_t(1) << 62;
}  // namespace

TEST_CASE("shape: an element count past 2^60 - 1 is refused with the shape named", "[autodiff][shape][errors]") {
  CHECK_THROWS_AS(Shape({k2p31, k2p31}), ShapeError);
  CHECK_THROWS_WITH(Shape({k2p31, k2p31}), Catch::Contains("[2147483648, 2147483648]"));
  CHECK_THROWS_AS(Shape({k2p62, 4}), ShapeError);  // wrapped to numel 0 before
  CHECK_THROWS_AS(Shape({std::int64_t(1) << 60}), ShapeError);
  CHECK(Shape({Shape::kMaxElements}).numel() == Shape::kMaxElements);
  CHECK(Shape({std::int64_t(1) << 30, std::int64_t(1) << 29}).numel() == std::int64_t(1) << 59);
}

TEST_CASE("shape: zero extents do not hide an overflowing product", "[autodiff][shape][errors]") {
  // numel would be 0, but strides would still overflow.
  CHECK_THROWS_AS(Shape({0, k2p62, 4}), ShapeError);
  CHECK(Shape({0, k2p31, k2p31 / 8}).numel() == 0);
}

TEST_CASE("shape: factories refuse overflowing shapes instead of handing out a small buffer", "[autodiff][shape][errors]") {
  CHECK_THROWS_AS(Tensor::empty({k2p31, k2p31}), ShapeError);
  CHECK_THROWS_AS(Tensor::zeros({k2p31, k2p31}, DType::Float64), ShapeError);
  CHECK_THROWS_AS(Tensor::full({k2p62, 4}, 1.0), ShapeError);
}

TEST_CASE("shape: concat refuses a sum of extents past the limit", "[autodiff][shape][errors]") {
  // Zero-element tensors with huge extents cost no memory; their sum overflows int64.
  const std::vector<Tensor> parts(9, Tensor::empty({Shape::kMaxElements, 0}));
  CHECK_THROWS_AS(concat(parts, 0), ShapeError);
  CHECK_THROWS_WITH(concat(parts, 0), Catch::Contains("concat"));
  CHECK_THROWS_AS(concat({parts[0], parts[0]}, 0), ShapeError);
  CHECK(concat({parts[0]}, 0).shape() == Shape({Shape::kMaxElements, 0}));
}

TEST_CASE("shape: reshape refuses target extents whose product overflows", "[autodiff][shape][errors]") {
  Tensor a = Tensor::zeros({0});
  CHECK_THROWS_AS(reshape(a, {k2p62, 4, 0}), ShapeError);  // product wraps to 0 == numel
  CHECK_THROWS_WITH(reshape(a, {k2p62, 4, -1}), Catch::Contains("reshape"));
  CHECK(reshape(a, {k2p31, 0}).shape() == Shape({k2p31, 0}));
}

TEST_CASE("shape: matmul and broadcasting refuse result shapes past the limit", "[autodiff][shape][errors]") {
  Tensor a = Tensor::zeros({k2p31, 0});
  Tensor b = Tensor::zeros({0, k2p31});
  CHECK_THROWS_AS(matmul(a, b), ShapeError);
  Tensor c = Tensor::zeros({k2p31, 1, 0});
  Tensor d = Tensor::zeros({1, k2p31, 0});
  CHECK_THROWS_AS(c + d, ShapeError);
}
