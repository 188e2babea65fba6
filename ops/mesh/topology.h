// Mesh topology shared by the mesh ops (internal): the input check of a mesh
// (positions and triangles) and its distinct undirected edges, built once,
// serially, in a fixed order, so everything derived from them is the same for
// any thread count.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr::detail {

// positions: float32 or float64 [V, 3], finite; triangles: int32 [F, 3] with
// every index in [0, V). Throws the matching gr::Error naming `op` and the argument.
void check_mesh(const Tensor& positions, const Tensor& triangles, const std::string& op);

// The distinct undirected edges of a triangle list. Side k of face f is the
// edge opposite corner k, between corners k + 1 and k + 2 (mod 3). A face
// repeating an index has a side (i, i), kept as an edge (as PyTorch3D's
// Meshes.edges_packed keeps it).
struct MeshEdges {
  std::vector<std::int32_t> lo, hi;     // edge e = (lo[e], hi[e]), lo <= hi, sorted by (lo, hi)
  std::vector<std::int64_t> side_edge;  // [3F]: side 3 f + k -> its edge
  std::int64_t size() const { return std::int64_t(lo.size()); }
};
// Triangles as check_mesh checked them (int32 [F, 3], indices in [0, num_vertices)).
MeshEdges mesh_edges(const Tensor& triangles, std::int64_t num_vertices);

// Compressed rows (CSR) of per-vertex neighbour lists: row i's entries are
// [start[i], start[i + 1]) of `column` and `edge`.
struct VertexRows {
  std::vector<std::int64_t> start;   // [V + 1]
  std::vector<std::int32_t> column;  // neighbour indices, ascending within a row
  std::vector<std::int64_t> edge;    // each entry's edge (index into MeshEdges)
  std::int64_t rows() const { return std::int64_t(start.size()) - 1; }
};
// The uniform graph rows: for each distinct edge (i, j), j in row i and i in
// row j; with self_edges, an edge (i, i) lists i twice in row i (PyTorch3D's
// uniform Laplacian), without, it is dropped (the large-steps graph).
VertexRows edge_rows(const MeshEdges& edges, std::int64_t num_vertices, bool self_edges);

// A zero scalar of positions' dtype, connected to positions on the tape with a
// zero gradient (the sum of no element): the losses of a mesh without terms.
Tensor zero_loss(const Tensor& positions);

}  // namespace gr::detail
