// Tensors made to match another one, and int32 index tensors from the integer
// types that index buffers and mesh loaders hold (uint32, int64).
#pragma once

#include <cstdint>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

// New leaves (not requiring grad) with `like`'s shape and dtype.
Tensor zeros_like(const Tensor& like);
Tensor ones_like(const Tensor& like);
Tensor full_like(const Tensor& like, double value);

// An int32 tensor of `shape` holding `values` (values.size() must equal
// shape.numel(), else ShapeError). Every value must lie in [0, 2^31 - 1]; the
// first that does not throws IndexError naming its position and value.
Tensor index_tensor(const std::vector<std::uint32_t>& values, const Shape& shape);
Tensor index_tensor(const std::vector<std::int64_t>& values, const Shape& shape);
// Triangle indices [M, 3] from a flat list of 3M vertex indices (ShapeError if
// the count is not a multiple of 3), checked as index_tensor does.
Tensor triangle_indices(const std::vector<std::uint32_t>& values);
Tensor triangle_indices(const std::vector<std::int64_t>& values);

}  // namespace gr
