// detail::TensorStamp (ops/render/tensor_stamp.h): what the device copies of
// G-buffers, projections and textures trust to tell that a tensor is still
// the one they were made from.
#include <catch2/catch.hpp>

#include <memory>
#include <utility>

#include "ops/ops.h"
#include "ops/render/tensor_stamp.h"

using namespace gr;
using gr::detail::TensorStamp;

TEST_CASE("a tensor stamp matches its tensor and its copies of the handle until an in-place write", "[stamp]") {
  Tensor t = Tensor::from_values({1.0, 2.0, 3.0, 4.0}, {2, 2});
  const TensorStamp stamp = TensorStamp::of(t);
  const Tensor same_handle = t;
  CHECK(stamp.matches(t));
  CHECK(stamp.matches(same_handle));
  CHECK_FALSE(stamp.stale());
  std::as_const(t).data<float>();  // a read is not a write
  CHECK(stamp.matches(t));
  t.data<float>()[0] = 1.0f;  // a write through the mutable pointer counts, even of the same value
  CHECK_FALSE(stamp.matches(t));
  CHECK(stamp.stale());
  CHECK(TensorStamp::of(t).matches(t));
}

TEST_CASE("a tensor stamp does not match a tensor of equal values, shape or dtype elsewhere", "[stamp]") {
  const Tensor t = Tensor::from_values({1.0, 2.0, 3.0, 4.0}, {2, 2});
  const TensorStamp stamp = TensorStamp::of(t);
  CHECK_FALSE(stamp.matches(Tensor::from_values({1.0, 2.0, 3.0, 4.0}, {2, 2})));
  CHECK_FALSE(stamp.matches(reshape(t, {4})));
  CHECK_FALSE(stamp.matches(Tensor::from_values({1.0, 2.0, 3.0, 4.0}, {2, 2}, DType::Float64)));
  CHECK_FALSE(stamp.matches(Tensor()));
}

TEST_CASE("a tensor stamp keeps nothing alive and is stale once its storage is gone", "[stamp]") {
  auto t = std::make_unique<Tensor>(Tensor::from_values({1.0, 2.0}, {2}));
  const TensorStamp stamp = TensorStamp::of(*t);
  CHECK_FALSE(stamp.stale());
  t.reset();
  CHECK(stamp.stale());
}

TEST_CASE("the stamp of no tensor matches only no tensor and is never stale", "[stamp]") {
  const TensorStamp none = TensorStamp::of(Tensor());
  CHECK(none.matches(Tensor()));
  CHECK_FALSE(none.matches(Tensor::from_values({1.0}, {1})));
  CHECK_FALSE(none.stale());
}
