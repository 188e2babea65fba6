// Reductions: sum and mean over all elements or along one axis.
//
// Results are bit-identical for any thread count (fixed blocks, summed in
// order); float32 inputs are accumulated in double.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

// Sum of all elements (a rank-0 tensor). dL/da = g broadcast to a's shape.
Tensor sum(const Tensor& a);
// Sum along `axis` (negative counts from the end); keepdim keeps it as extent 1.
Tensor sum(const Tensor& a, int axis, bool keepdim = false);
// Mean of all elements. dL/da = g / numel.
Tensor mean(const Tensor& a);
Tensor mean(const Tensor& a, int axis, bool keepdim = false);

// Sums `a` over broadcast axes so that it has `shape` (the adjoint of
// broadcasting); `shape` must broadcast to a's shape. Differentiable.
Tensor sum_to_shape(const Tensor& a, const Shape& shape);
// Repeats `a` along broadcast axes to `shape` (materialized). Differentiable.
Tensor broadcast_to(const Tensor& a, const Shape& shape);

}  // namespace gr
