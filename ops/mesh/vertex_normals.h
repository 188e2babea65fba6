// Area-weighted vertex normals of a triangle mesh, differentiable with
// respect to the vertex positions.
#pragma once

#include "autodiff/base/tensor.h"
#include "ops/tensor/vector.h"

namespace gr {

// Unit vertex normals [V, 3] of positions [V, 3] (float32 or float64) and
// triangles [F, 3] (int32): each face's cross product (p1 - p0) x (p2 - p0)
// (length twice its area, pointing to the side from which p0, p1, p2 run
// counter-clockwise) is added to its three corners (in a fixed order, in
// parallel over vertices), and each sum s_i is divided by max(|s_i|, eps). A vertex of no face,
// or whose faces' normals cancel, gets 0. PyTorch3D's
// Meshes.verts_normals_packed, with eps = 1e-12 instead of its 1e-6; Python:
// gradraster.losses.vertex_normals. The sums are one op with a hand-derived
// adjoint (summed in double per vertex), followed by normalize.
Tensor vertex_normals(const Tensor& positions, const Tensor& triangles, double eps = kNormalizeEps);

}  // namespace gr
