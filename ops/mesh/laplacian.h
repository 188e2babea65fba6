// Mesh Laplacians as sparse linear operators on per-vertex values, with
// PyTorch3D's definitions (pytorch3d.ops.laplacian, cot_laplacian), built once
// from a triangle list (and, for cotangent weights, the positions) and applied
// as one recorded op.
#pragma once

#include <cstdint>
#include <memory>

#include "autodiff/base/tensor.h"

namespace gr {

// Which Laplacian (PyTorch3D's mesh_laplacian_smoothing `method`).
enum class LaplacianMethod {
  Uniform,  // r_i = (1/deg_i) sum_{j in N(i)} x_j - x_i
  Cot,      // r_i = sum_j w_ij x_j / sum_j w_ij - x_i, w_ij = cot a_ij + cot b_ij
  CotCurv,  // r_i = sum_j w_ij (x_j - x_i) / (4 A_i)
};
// "uniform", "cot", "cotcurv" (Python's names).
const char* laplacian_method_name(LaplacianMethod method);

// The linear map x -> r = L x on values x [V, C] (any C):
// - Uniform: N(i) the distinct edge neighbours of i (a side (i, i) of a face
//   repeating an index lists i twice, as PyTorch3D's Meshes.laplacian_packed);
//   an isolated vertex has r_i = -x_i.
// - Cot: w_ij sums, over the faces with side (i, j), the cotangent of the angle
//   opposite it, cot = (b^2 + c^2 - a^2) / (4 area) per corner (a the opposite
//   side, area by Heron's formula with area^2 clamped to >= 1e-12, so a
//   zero-area face gives large finite weights). A row whose weights sum to
//   s_i <= 0 is multiplied by s_i instead of divided (PyTorch3D's rule; an
//   isolated vertex has r_i = -x_i).
// - CotCurv: the same w_ij; A_i the summed area of the faces at i (an isolated
//   vertex: r_i = 0).
// The weights are computed once, in float64, from the positions given to the
// constructor (values only: constants for the gradient, as PyTorch3D computes
// them under no_grad) and rounded to x's dtype in apply.
class MeshLaplacian {
 public:
  // The uniform Laplacian of `triangles` (int32 [F, 3], indices in [0, num_vertices)).
  MeshLaplacian(const Tensor& triangles, std::int64_t num_vertices);
  // Any method; positions (float32 or float64 [V, 3], finite) give V and the
  // cotangent weights (not used by Uniform).
  MeshLaplacian(const Tensor& positions, const Tensor& triangles, LaplacianMethod method);

  // r = L x for x [V, C], float32 or float64; one recorded op, in parallel over
  // rows, each row's sum in ascending neighbour order (bit-identical for any
  // thread count). Adjoint: dL/dx = L^T g (W is symmetric, the row scales are not):
  //   Uniform, Cot: L x = S W x - x,          L^T g = W (S g) - g
  //   CotCurv:      L x = S (W x - D x),      L^T g = W (S g) - D (S g)
  // with S the row scales (1/deg_i, 1/s_i, 1/(4 A_i)) and D = diag(s_i).
  Tensor apply(const Tensor& x) const;
  // (I + step L)^passes x for x [V, C], float32 or float64: `passes` times
  // x <- x + step * apply(x), as one recorded op with the bits of that
  // composite (value and gradient; step is rounded to x's dtype first). Its
  // adjoint needs no saved values: g <- g + L^T (step g), passes times.
  // passes = 0 returns x. Throws for passes < 0 or a non-finite step.
  Tensor smooth(const Tensor& x, int passes, double step) const;
  // The matrix of apply, dense [V, V] float64 (for checks on small meshes).
  Tensor to_dense() const;

  LaplacianMethod method() const { return method_; }
  std::int64_t num_vertices() const { return num_vertices_; }

  struct Operator;  // the rows, weights and scales (defined in laplacian.cpp)

 private:
  std::shared_ptr<const Operator> op_;  // shared with recorded adjoints
  LaplacianMethod method_;
  std::int64_t num_vertices_;
};

}  // namespace gr
