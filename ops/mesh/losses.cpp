// Mesh losses: the edge loss and normal consistency as composites of tensor
// ops over index lists built once from the mesh's edges; Laplacian smoothing
// through MeshLaplacian. Deterministic as their parts are.
#include "ops/mesh/losses.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "ops/tensor/elementwise.h"
#include "ops/mesh/topology.h"
#include "ops/tensor/reduce.h"
#include "ops/tensor/shape_ops.h"
#include "ops/tensor/vector.h"

namespace gr {
namespace {

Tensor index_tensor(const std::vector<std::int32_t>& index) {
  return Tensor::from_vector(index, {std::int64_t(index.size())});
}

}  // namespace

Tensor mesh_edge_loss(const Tensor& positions, const Tensor& triangles, double target_length) {
  detail::check_mesh(positions, triangles, "mesh_edge_loss");
  if (!std::isfinite(target_length))
    throw ValueError("mesh_edge_loss: argument 'target_length' must be finite, got " + std::to_string(target_length));
  if (triangles.size(0) == 0) return detail::zero_loss(positions);
  const detail::MeshEdges edges = detail::mesh_edges(triangles, positions.size(0));
  const Tensor d = gather(positions, index_tensor(edges.lo)) - gather(positions, index_tensor(edges.hi));
  return mean(pow(length(d) - target_length, 2.0));
}

Tensor mesh_laplacian_smoothing(const Tensor& positions, const Tensor& triangles, LaplacianMethod method) {
  detail::check_mesh(positions, triangles, "mesh_laplacian_smoothing");
  if (triangles.size(0) == 0) return detail::zero_loss(positions);
  const MeshLaplacian laplacian(positions.detach(), triangles, method);
  return mean(length(laplacian.apply(positions)));
}

Tensor mesh_normal_consistency(const Tensor& positions, const Tensor& triangles, double eps) {
  detail::check_mesh(positions, triangles, "mesh_normal_consistency");
  if (!(eps > 0) || !std::isfinite(eps))
    throw ValueError("mesh_normal_consistency: argument 'eps' must be positive and finite, got " +
                     std::to_string(eps));
  if (triangles.size(0) == 0) return detail::zero_loss(positions);
  const detail::MeshEdges edges = detail::mesh_edges(triangles, positions.size(0));
  const std::int64_t sides = 3 * triangles.size(0);
  // Each edge's sides, in side order: sides grouped by edge (a counting sort).
  std::vector<std::int64_t> start(static_cast<std::size_t>(edges.size()) + 1, 0);
  for (std::int64_t s = 0; s < sides; ++s) ++start[edges.side_edge[s] + 1];
  for (std::int64_t e = 0; e < edges.size(); ++e) start[e + 1] += start[e];
  std::vector<std::int32_t> by_edge(static_cast<std::size_t>(sides));
  std::vector<std::int64_t> next(start.begin(), start.end() - 1);
  for (std::int64_t s = 0; s < sides; ++s) by_edge[next[edges.side_edge[s]]++] = std::int32_t(s);
  // Every unordered pair (p, q), p before q, of sides on one edge.
  std::vector<std::int32_t> first, second;
  for (std::int64_t e = 0; e < edges.size(); ++e)
    for (std::int64_t p = start[e]; p < start[e + 1]; ++p)
      for (std::int64_t q = p + 1; q < start[e + 1]; ++q) {
        first.push_back(by_edge[p]);
        second.push_back(by_edge[q]);
      }
  if (first.empty()) return detail::zero_loss(positions);
  // One normal per face side s = 3 f + k on edge (a, b):
  // n = (p_b - p_a) x (p0 + p1 + p2 - 3 p_a), p0..p2 the corners of face f.
  std::vector<std::int32_t> side_face(static_cast<std::size_t>(sides)), side_a(side_face.size()),
      side_b(side_face.size());
  for (std::int64_t s = 0; s < sides; ++s) {
    side_face[s] = std::int32_t(s / 3);
    side_a[s] = edges.lo[edges.side_edge[s]];
    side_b[s] = edges.hi[edges.side_edge[s]];
  }
  const std::int64_t nf = triangles.size(0);
  const Tensor corners = gather(positions, reshape(triangles, {3 * nf}));  // [3F, 3]
  const Tensor c3 = reshape(corners, {nf, 3, 3});
  const Tensor corner_sum = sum(c3, 1);  // [F, 3]
  const Tensor pa = gather(positions, index_tensor(side_a));
  const Tensor pb = gather(positions, index_tensor(side_b));
  const Tensor n = cross(pb - pa, gather(corner_sum, index_tensor(side_face)) - 3.0 * pa);  // [3F, 3]
  const Tensor n0 = gather(n, index_tensor(first)), n1 = -gather(n, index_tensor(second));
  const Tensor cos = dot(n0, n1) / (maximum(length(n0), eps) * maximum(length(n1), eps));
  return mean(1.0 - cos);
}

}  // namespace gr
