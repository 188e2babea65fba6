// Matrix products and transposes.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

// Matrix product over the last two axes with broadcasting of leading (batch)
// axes: [..., n, k] x [..., k, m] -> [..., n, m]. Rank-1 operands are not
// promoted (use reshape). dL/da = g b^T, dL/db = a^T g (summed over broadcast
// batch axes).
Tensor matmul(const Tensor& a, const Tensor& b);
// Swaps the last two axes (materialized); int32 allowed. dL/da = transpose(g).
Tensor transpose(const Tensor& a);
// Points [..., 3] -> homogeneous [..., 4] with w = 1. dL/dp = g[..., :3].
Tensor to_homogeneous(const Tensor& points);
// Transforms N x 3 points (or N x 4 homogeneous) by a 4 x 4 matrix M
// (column-vector convention: p' = M p), returning N x 4. Composite
// matmul(P_h, transpose(M)): dL/dP_h = g M, dL/dM = g^T P_h.
Tensor transform_points(const Tensor& points, const Tensor& matrix);

}  // namespace gr
