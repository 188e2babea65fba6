// Vertex normals and the uniform Laplacian, built from gather / scatter_add so
// both are differentiable with respect to the vertex positions.
#include "examples/fit/geometry.h"

#include <set>
#include <utility>
#include <vector>

#include "ops/ops.h"

namespace fit {

using namespace gr;

namespace {

// Column k of an int32 [M, 3] triangle list as an [M] index tensor.
Tensor corner(const Tensor& triangles, int k) {
  return reshape(slice(triangles, 1, k, k + 1), {triangles.size(0)});
}

}  // namespace

Tensor vertex_normals(const Tensor& positions, const Tensor& triangles) {
  const Tensor i0 = corner(triangles, 0), i1 = corner(triangles, 1), i2 = corner(triangles, 2);
  const Tensor p0 = gather(positions, i0);
  const Tensor face = cross(gather(positions, i1) - p0, gather(positions, i2) - p0);  // [M, 3]
  const Tensor corners = concat({i0, i1, i2}, 0);                                     // [3M]
  const Tensor summed = scatter_add(concat({face, face, face}, 0), corners, positions.size(0));
  return normalize(summed);
}

UniformLaplacian::UniformLaplacian(const Tensor& triangles, std::int64_t num_vertices)
    : num_vertices_(num_vertices) {
  // Unique undirected edges (works for closed and open meshes alike).
  std::set<std::pair<std::int32_t, std::int32_t>> edges;
  const std::int32_t* t = triangles.data<std::int32_t>();
  for (std::int64_t f = 0; f < triangles.size(0); ++f)
    for (int k = 0; k < 3; ++k) {
      std::int32_t a = t[3 * f + k], b = t[3 * f + (k + 1) % 3];
      if (a > b) std::swap(a, b);
      if (a != b) edges.insert({a, b});
    }
  std::vector<std::int32_t> from, to;
  std::vector<double> degree(static_cast<std::size_t>(num_vertices), 0.0);
  for (const auto& [a, b] : edges) {
    from.push_back(a), to.push_back(b);
    from.push_back(b), to.push_back(a);
    degree[a] += 1, degree[b] += 1;
  }
  for (double& d : degree) d = d > 0 ? 1.0 / d : 0.0;
  const std::int64_t e = static_cast<std::int64_t>(from.size());
  from_ = Tensor::from_vector(from, {e});
  to_ = Tensor::from_vector(to, {e});
  inv_degree_ = Tensor::from_values(degree, {num_vertices, 1});
}

Tensor UniformLaplacian::apply(const Tensor& positions) const {
  const Tensor neighbour_sum = scatter_add(gather(positions, to_), from_, num_vertices_);
  return positions - neighbour_sum * cast(inv_degree_, positions.dtype());
}

Tensor UniformLaplacian::penalty(const Tensor& positions) const {
  const Tensor l = apply(positions);
  return mean(sum(l * l, -1));
}

}  // namespace fit
