// Mesh regularizers with PyTorch3D's definitions (pytorch3d.loss), for one
// mesh: positions [V, 3] (float32 or float64, finite) and triangles [F, 3]
// (int32, indices in [0, V)); faces may repeat an index (a degenerate face)
// and vertices of no face are allowed. Each returns a rank-0 tensor of
// positions' dtype, differentiable with respect to the positions. Python:
// gradraster.losses (same names and definitions; docs/mesh_losses.md).
#pragma once

#include "autodiff/base/tensor.h"
#include "ops/mesh/laplacian.h"

namespace gr {

// Mean over the mesh's distinct edges (i, j) of (|p_i - p_j| - target_length)^2
// (an edge shared by several faces counts once; a side (i, i) of a degenerate
// face is an edge of length 0). A mesh without faces gives 0. At a zero-length
// edge the gradient of |p_i - p_j| is taken as 0. A composite of gather,
// length, pow and mean.
Tensor mesh_edge_loss(const Tensor& positions, const Tensor& triangles, double target_length = 0.0);

// Mean over all V vertices of |r_i|, r = L p the Laplacian of the positions
// (MeshLaplacian, built from the positions' current values: its weights are
// constants for the gradient, as in PyTorch3D). A mesh without faces gives 0.
// dL/dp = L^T (r_i / |r_i|) / V (0 where r_i = 0).
Tensor mesh_laplacian_smoothing(const Tensor& positions, const Tensor& triangles,
                                LaplacianMethod method = LaplacianMethod::Uniform);

// Mean over all pairs of faces sharing an edge of 1 - cos(n_0, n_1). For an
// edge (a, b), a < b, and a face on it with third vertex w,
// n = (p_b - p_a) x (p_w - p_a); two faces with third vertices w0, w1 give
// 1 - cos(n(w0), -n(w1)): 0 when they lie flat, 2 when folded onto each other,
// whatever their orientation. An edge of k faces gives k (k - 1) / 2 pairs. A
// face repeating an index has n = (p_b - p_a) x (p0 + p1 + p2 - 3 p_a) (its
// three corners summed, as PyTorch3D). cos(x, y) = x.y / (max(|x|, eps)
// max(|y|, eps)); a zero-area face has n = 0 and terms of 1. A mesh with no
// edge of two faces gives 0. A composite of gather, cross, length, dot and mean.
Tensor mesh_normal_consistency(const Tensor& positions, const Tensor& triangles, double eps = 1e-8);

}  // namespace gr
