// Gradient accumulation used by the tape: dst += src, adopting src when dst is
// empty and adding in place when dst's storage is not shared.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

void accumulate_into(Tensor& dst, const Tensor& src);

// leaf.grad += grad, safe when several threads backpropagate into the same leaf:
// no contribution is lost, but their order (hence the float rounding) is the
// order in which the threads arrive.
void accumulate_leaf_grad(TensorImpl& leaf, const Tensor& grad);

// Gives the leaf a zero gradient of its shape if it has none, under the same
// lock as accumulate_leaf_grad (another thread may be adding into it).
void ensure_leaf_grad(TensorImpl& leaf, const Shape& shape, DType dtype);

}  // namespace gr
