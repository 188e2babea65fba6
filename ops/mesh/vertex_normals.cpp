// Vertex normals as a composite of gather, cross, scatter_add and normalize
// (deterministic as they are: scatter_add adds duplicates in a fixed order).
#include "ops/mesh/vertex_normals.h"

#include <cmath>
#include <string>

#include "autodiff/base/error.h"

#include "ops/mesh/topology.h"
#include "ops/tensor/shape_ops.h"
#include "ops/tensor/elementwise.h"

namespace gr {
namespace {

// Column k of an int32 [F, 3] triangle list as an [F] index tensor.
Tensor corner(const Tensor& triangles, int k) {
  return reshape(slice(triangles, 1, k, k + 1), {triangles.size(0)});
}

}  // namespace

Tensor vertex_normals(const Tensor& positions, const Tensor& triangles, double eps) {
  detail::check_mesh(positions, triangles, "vertex_normals");
  if (!(eps > 0) || !std::isfinite(eps))
    throw ValueError("vertex_normals: argument 'eps' must be positive and finite, got " + std::to_string(eps));
  const Tensor i0 = corner(triangles, 0), i1 = corner(triangles, 1), i2 = corner(triangles, 2);
  const Tensor p0 = gather(positions, i0);
  const Tensor face = cross(gather(positions, i1) - p0, gather(positions, i2) - p0);  // [F, 3]
  const Tensor corners = concat({i0, i1, i2}, 0);                                     // [3F]
  const Tensor summed = scatter_add(concat({face, face, face}, 0), corners, positions.size(0));
  return normalize(summed, eps);
}

}  // namespace gr
