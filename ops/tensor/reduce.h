// Reductions: sum and mean over all elements or along one axis.
//
// Results are bit-identical for any thread count (fixed blocks, summed in
// order); float32 inputs are accumulated in double.
#pragma once

#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

// Sum of all elements (a rank-0 tensor). dL/da = g broadcast to a's shape.
Tensor sum(const Tensor& a);
// Sum along `axis` (negative counts from the end); keepdim keeps it as extent 1.
Tensor sum(const Tensor& a, int axis, bool keepdim = false);
// Mean of all elements. dL/da = g / numel.
Tensor mean(const Tensor& a);
Tensor mean(const Tensor& a, int axis, bool keepdim = false);

// sum over k of sum(values[k] * weights[k]) (a rank-0 tensor of values'
// dtype; each pair same shape and dtype, at least one pair), accumulated in
// double: a linear form with constant weights. dL/dvalues[k] = g weights[k]
// (weights[k] itself for g = 1, the bits of the sum-of-products composite's
// gradient, without its products and broadcasts). The weights get no
// gradient: one that requires one while recording is refused (detach() it).
Tensor sum_of_products(const std::vector<Tensor>& values, const std::vector<Tensor>& weights);

// Sums `a` over broadcast axes so that it has `shape` (the adjoint of
// broadcasting); `shape` must broadcast to a's shape. Differentiable.
Tensor sum_to_shape(const Tensor& a, const Shape& shape);
// Repeats `a` along broadcast axes to `shape` (materialized). Differentiable.
Tensor broadcast_to(const Tensor& a, const Shape& shape);

}  // namespace gr
