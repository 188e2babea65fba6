// The vertex weld behind build_edge_topology (raster/antialias.h), in two
// steps, so that a caller can keep a weld and test it against new positions:
// weld_vertices names each vertex by the smallest index among the vertices
// with the same position row; build_edge_topology_welded pairs the edges of
// those named vertices. build_edge_topology(tris, m, n, pos, dims) is
// build_edge_topology_welded(tris, m, weld_vertices(pos, n, dims)), bit for bit.
#pragma once

#include <cstdint>
#include <vector>

#include "raster/antialias.h"

namespace gr::raster {

// canonical[v] = the smallest u with row u equal to row v: every component
// equal under == (so -0 and +0 are equal). positions: num_vertices x dims
// row-major, finite; null or dims < 1: no weld (canonical[v] = v).
template <class T>
std::vector<std::int32_t> weld_vertices(const T* positions, std::int64_t num_vertices, int dims);

// True when weld_vertices(positions, canonical.size(), dims) == canonical,
// found in O(n) without sorting: every row equals its canonical vertex's row,
// and the canonical vertices' rows are pairwise distinct (a hash table). Any
// vector is accepted (one not of weld_vertices' form gives false).
template <class T>
bool weld_holds(const T* positions, int dims, const std::vector<std::int32_t>& canonical);

// The edge topology of tris (M x 3, each index in [0, canonical.size())),
// vertices compared by canonical id (as weld_vertices gives them).
EdgeTopology build_edge_topology_welded(const std::int32_t* tris, std::int64_t num_tris,
                                        const std::vector<std::int32_t>& canonical);

}  // namespace gr::raster
