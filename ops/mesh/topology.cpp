// The mesh input check and the distinct edges of a triangle list: one sort of
// the 3F face sides by their (smaller, larger) vertex pair.
#include "ops/mesh/topology.h"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <utility>

#include "autodiff/base/dtype.h"
#include "ops/check.h"
#include "ops/tensor/shape_ops.h"
#include "ops/tensor/reduce.h"

namespace gr::detail {

void check_mesh(const Tensor& positions, const Tensor& triangles, const std::string& op) {
  check_float(positions, op, "positions");
  check_columns(positions, 3, op, "positions", "V");
  check_finite(positions, op, "positions");
  check_triangles(triangles, positions.size(0), op);
}

MeshEdges mesh_edges(const Tensor& triangles, std::int64_t num_vertices) {
  return guard_allocation("mesh edges", [&] {
    const std::int32_t* t = triangles.data<std::int32_t>();
    const std::int64_t sides = 3 * triangles.size(0);
    // Each side's key lo * V + hi; sides sorted by key (ties by side index).
    // Indices are int32, so V beyond 2^31 orders the keys no differently and
    // would only overflow lo * V.
    const std::int64_t stride = std::min(num_vertices, std::int64_t(1) << 31);
    std::vector<std::int64_t> key(static_cast<std::size_t>(sides));
    for (std::int64_t s = 0; s < sides; ++s) {
      const std::int64_t f = s / 3, k = s % 3;
      const std::int32_t a = t[3 * f + (k + 1) % 3], b = t[3 * f + (k + 2) % 3];
      key[s] = std::int64_t(std::min(a, b)) * stride + std::max(a, b);
    }
    std::vector<std::int64_t> order(static_cast<std::size_t>(sides));
    std::iota(order.begin(), order.end(), std::int64_t(0));
    std::stable_sort(order.begin(), order.end(), [&](std::int64_t x, std::int64_t y) { return key[x] < key[y]; });
    MeshEdges e;
    e.side_edge.resize(static_cast<std::size_t>(sides));
    for (std::size_t n = 0; n < order.size(); ++n) {
      const std::int64_t k = key[order[n]];
      if (n == 0 || k != key[order[n - 1]]) {
        e.lo.push_back(std::int32_t(k / stride));
        e.hi.push_back(std::int32_t(k % stride));
      }
      e.side_edge[order[n]] = e.size() - 1;
    }
    return e;
  });
}

VertexRows edge_rows(const MeshEdges& edges, std::int64_t num_vertices, bool self_edges) {
  return guard_allocation("mesh edge rows", [&] {
    std::vector<std::int64_t> count(static_cast<std::size_t>(num_vertices), 0);
    for (std::int64_t e = 0; e < edges.size(); ++e) {
      if (edges.lo[e] == edges.hi[e] && !self_edges) continue;
      ++count[edges.lo[e]];
      ++count[edges.hi[e]];
    }
    VertexRows r;
    r.start.assign(static_cast<std::size_t>(num_vertices) + 1, 0);
    for (std::int64_t i = 0; i < num_vertices; ++i) r.start[i + 1] = r.start[i] + count[i];
    // (column, edge) pairs per row, sorted by column (equal columns: one self edge).
    std::vector<std::pair<std::int32_t, std::int64_t>> entry(static_cast<std::size_t>(r.start.back()));
    std::vector<std::int64_t> next(r.start.begin(), r.start.end() - 1);
    for (std::int64_t e = 0; e < edges.size(); ++e) {
      if (edges.lo[e] == edges.hi[e] && !self_edges) continue;
      entry[next[edges.lo[e]]++] = {edges.hi[e], e};
      entry[next[edges.hi[e]]++] = {edges.lo[e], e};
    }
    for (std::int64_t i = 0; i < num_vertices; ++i)
      std::sort(entry.begin() + r.start[i], entry.begin() + r.start[i + 1]);
    r.column.reserve(entry.size());
    r.edge.reserve(entry.size());
    for (const auto& [column, e] : entry) {
      r.column.push_back(column);
      r.edge.push_back(e);
    }
    return r;
  });
}

Tensor zero_loss(const Tensor& positions) { return sum(slice(positions, 0, 0, 0)); }

}  // namespace gr::detail
