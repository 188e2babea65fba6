// The "large steps" reparametrization of vertex positions (Nicolet, Jacobson
// and Jakob 2021, "Large Steps in Inverse Rendering of Geometry"): optimize
// u = M x instead of the positions x, with M = I + lambda L, and map back
// with x = M^-1 u, so a gradient step on u moves x smoothly.
#pragma once

#include <cstdint>
#include <memory>

#include "autodiff/base/tensor.h"

namespace gr {

// M = I + lambda L (or (1 - alpha) I + alpha L), L = D - A the combinatorial
// (uniform, unnormalized) graph Laplacian of the mesh's distinct edges (A the
// adjacency, D the degrees; sides (i, i) of degenerate faces dropped): the
// matrix of the `largesteps` package's compute_matrix (cotan=False) and of
// Python's gradraster.losses.LargeSteps. M is symmetric positive definite; it
// is built once as a sparse matrix and factored once (sparse Cholesky, in
// float64, serial, so every result is the same for any thread count).
//
//   LargeSteps ls(positions, triangles, 20.0);
//   Tensor u = ls.to_differential(positions).detach().set_requires_grad();
//   // each step: Tensor x = ls.from_differential(u); ... backward(loss); adam.step();
class LargeSteps {
 public:
  // positions: float32 or float64 [V, 3], finite (only V is used);
  // triangles: int32 [F, 3] in [0, V); lambda >= 0 and finite.
  LargeSteps(const Tensor& positions, const Tensor& triangles, double lambda);
  // M = (1 - alpha) I + alpha L, alpha in [0, 1).
  static LargeSteps with_alpha(const Tensor& positions, const Tensor& triangles, double alpha);

  // u = M x for x [V, C] (float32 or float64; u has x's dtype): per row
  // u_i = a x_i + b (deg_i x_i - sum_{j in N(i)} x_j), the sum in ascending j,
  // in parallel over rows. One recorded op; dL/dx = M g (M is symmetric).
  Tensor to_differential(const Tensor& x) const;
  // x = M^-1 u for u [V, C] (float32 or float64; x has u's dtype): every
  // column solved in float64 with the factor. One recorded op;
  // dL/du = M^-1 g, the same solve of the incoming gradient.
  Tensor from_differential(const Tensor& u) const;
  // M as a dense [V, V] float64 tensor (for checks on small meshes).
  Tensor matrix() const;

  std::int64_t num_vertices() const { return num_vertices_; }
  double diagonal_weight() const { return diag_weight_; }    // a: 1, or 1 - alpha
  double laplacian_weight() const { return lap_weight_; }    // b: lambda, or alpha

  struct Factor;  // the graph rows and the Cholesky factor (large_steps.cpp)

 private:
  LargeSteps(const Tensor& positions, const Tensor& triangles, double diag_weight, double lap_weight,
             const char* op);
  std::shared_ptr<const Factor> factor_;  // shared with recorded adjoints
  std::int64_t num_vertices_ = 0;
  double diag_weight_ = 1, lap_weight_ = 0;
};

}  // namespace gr
