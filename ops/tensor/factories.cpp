#include "ops/tensor/factories.h"

#include <limits>
#include <string>

namespace gr {
namespace {

const Tensor& checked_like(const Tensor& like, const char* op) {
  if (!like.defined()) throw ValueError(std::string(op) + ": argument 'like' is an undefined tensor");
  return like;
}

template <class I>
Tensor indices_to_int32(const std::vector<I>& values, const Shape& shape, const char* op) {
  if (static_cast<std::int64_t>(values.size()) != shape.numel())
    throw ShapeError(std::string(op) + ": " + std::to_string(values.size()) + " values do not fill shape " +
                     shape.str());
  constexpr std::int64_t kMax = std::numeric_limits<std::int32_t>::max();
  Tensor out = Tensor::empty(shape, DType::Int32);
  std::int32_t* d = out.data<std::int32_t>();
  for (std::size_t i = 0; i < values.size(); ++i) {
    // Compared as int64, so a uint32 above 2^31 - 1 and a negative int64 both fail.
    const std::int64_t v = static_cast<std::int64_t>(values[i]);
    if (v < 0 || v > kMax)
      throw IndexError(std::string(op) + ": value " + std::to_string(values[i]) + " at position " + std::to_string(i) +
                       " is outside the int32 index range [0, " + std::to_string(kMax) + "]");
    d[i] = static_cast<std::int32_t>(v);
  }
  return out;
}

template <class I>
Tensor triangles_from(const std::vector<I>& values) {
  if (values.size() % 3 != 0)
    throw ShapeError("triangle_indices: " + std::to_string(values.size()) + " indices are not a multiple of 3");
  return indices_to_int32(values, Shape{static_cast<std::int64_t>(values.size() / 3), 3}, "triangle_indices");
}

}  // namespace

Tensor zeros_like(const Tensor& like) {
  return Tensor::zeros(checked_like(like, "zeros_like").shape(), like.dtype());
}

Tensor ones_like(const Tensor& like) { return Tensor::ones(checked_like(like, "ones_like").shape(), like.dtype()); }

Tensor full_like(const Tensor& like, double value) {
  return Tensor::full(checked_like(like, "full_like").shape(), value, like.dtype());
}

Tensor index_tensor(const std::vector<std::uint32_t>& values, const Shape& shape) {
  return indices_to_int32(values, shape, "index_tensor");
}

Tensor index_tensor(const std::vector<std::int64_t>& values, const Shape& shape) {
  return indices_to_int32(values, shape, "index_tensor");
}

Tensor triangle_indices(const std::vector<std::uint32_t>& values) { return triangles_from(values); }
Tensor triangle_indices(const std::vector<std::int64_t>& values) { return triangles_from(values); }

}  // namespace gr
