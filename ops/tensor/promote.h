// dtype promotion for ops that combine float tensors arithmetically (the
// elementwise binary ops, comparisons, where, matmul, transform_points): a mix
// of float32 and float64 computes in float64, as in NumPy and PyTorch. The
// float32 operands go through a recorded cast(), so their gradients come back
// as float32. A double scalar still takes the tensor's dtype (x * 0.5 stays
// float32). Other ops (rasterize, interpolate, texture, concat...) require one
// dtype; cast() converts. See docs/decisions.md.
#pragma once

#include <initializer_list>

#include "autodiff/base/tensor.h"

namespace gr {

// float64 if either is float64, else float32 (both must be float types).
DType promote_types(DType a, DType b);

namespace detail {
// Casts every defined float32 tensor among `operands` to float64 when a
// defined one is float64. Undefined and int32 tensors are left for the op's
// own checks to report.
void promote_floats(std::initializer_list<Tensor*> operands);
}  // namespace detail

}  // namespace gr
