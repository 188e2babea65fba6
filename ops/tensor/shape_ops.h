// Ops that move elements without arithmetic: reshape, slicing, joining,
// indexing by int32 tensors. All differentiable with respect to float inputs;
// all accept int32 tensors too (no gradient).
#pragma once

#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

// Same elements, new shape (one extent may be -1 to infer it). Shares storage.
// dL/da = g viewed in a's shape.
Tensor reshape(const Tensor& a, const std::vector<std::int64_t>& shape);
// Elements [start, stop) with step along `axis`, with Python slice semantics:
// negative start/stop count from the end, out-of-range bounds are clamped, a
// negative step walks backwards (slice(a, 0, -1, -a.size(0) - 1, -1) reverses
// axis 0), step 0 throws ValueError. dL/da = g at the picked positions, 0 elsewhere.
Tensor slice(const Tensor& a, int axis, std::int64_t start, std::int64_t stop, std::int64_t step = 1);
// Joins tensors along an existing axis (all other extents equal).
// dL/d tensors[i] = the slice of g that tensors[i] filled.
Tensor concat(const std::vector<Tensor>& tensors, int axis);
// Joins equally shaped tensors along a new axis (in [-rank-1, rank]).
// dL/d tensors[i] = g's entry i along the new axis.
Tensor stack(const std::vector<Tensor>& tensors, int axis);
// Rows of `a` (along axis 0) picked by the int32 `index` tensor of any shape:
// result shape = index.shape + a.shape[1:]. Indices must lie in [0, a.size(0)).
// dL/da = scatter_add of g into the picked rows.
Tensor gather(const Tensor& a, const Tensor& index);
// A zeros tensor of shape [rows] + src.shape[index.rank:] with src's rows added
// at the rows named by `index` (duplicates accumulate in a fixed order, so the
// result does not depend on the thread count). dL/dsrc = gather(g, index).
Tensor scatter_add(const Tensor& src, const Tensor& index, std::int64_t rows);

}  // namespace gr
