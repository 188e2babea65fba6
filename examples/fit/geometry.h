// Differentiable mesh quantities for the fit example, written with tensor ops
// so gradients reach the vertex positions: area-weighted vertex normals and a
// uniform Laplacian smoothness penalty.
#pragma once

#include "autodiff/tensor.h"

namespace fit {

using gr::Tensor;

// Vertex normals [N, 3] of positions [N, 3] and triangles [M, 3]: each
// triangle's cross product (length = twice its area) is added to its three
// corners with scatter_add, then normalized.
Tensor vertex_normals(const Tensor& positions, const Tensor& triangles);

// The uniform ("umbrella") Laplacian of a fixed triangle list:
// L(p)_i = p_i - mean of p over the neighbours of vertex i.
class UniformLaplacian {
 public:
  UniformLaplacian(const Tensor& triangles, std::int64_t num_vertices);
  // L(p) [N, 3].
  Tensor apply(const Tensor& positions) const;
  // mean over vertices of |L(p)_i|^2: the smoothness penalty.
  Tensor penalty(const Tensor& positions) const;

 private:
  Tensor from_, to_;     // [E] int32: every undirected edge in both directions
  Tensor inv_degree_;    // [N, 1] float32: 1 / neighbour count
  std::int64_t num_vertices_;
};

}  // namespace fit
