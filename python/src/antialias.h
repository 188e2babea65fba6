// antialias in nvdiffrast's layout, and its topology "hash" (our edge
// adjacency, built from the triangle indices alone, as nvdiffrast's is);
// visibility_antialias (every visibility boundary, intersections included)
// through the same calls.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "python/src/common.h"
#include "python/src/rasterize.h"
#include "raster/blended_pairs.h"

namespace gr::python {

// antialias_construct_topology_hash(tri): adjacency by vertex index. The
// indices are checked first: against `vertices` when known (antialias), else
// for negatives only; the memory it takes grows with the triangles, never
// with an index (raster::build_edge_topology), and is checked against the
// memory budget. `op` names the caller in errors.
struct Topology {
  raster::EdgeTopology edges;
  std::int64_t triangles = 0;
};
std::shared_ptr<Topology> build_topology(Address tri, std::int64_t triangles, std::int64_t vertices,
                                         const std::string& op);

// What the backward needs: per image, the blended pixel pairs (of
// visibility_antialias when `visibility`).
struct AntialiasState {
  std::vector<raster::BlendedPairs> pairs;
};

// color, out: [images, H, W, C]; rast: the G-buffer for mesh. visibility:
// visibility_antialias instead of antialias.
std::shared_ptr<AntialiasState> antialias_forward(Context& ctx, const Mesh& mesh, const Topology& topology,
                                                  Address color, std::int64_t channels, int height, int width,
                                                  Address rast, Address out, bool visibility, int threads);
// Accumulates into grad_color (zeroed, or 0) and grad_pos (zeroed, or 0);
// the position gradient is multiplied by pos_gradient_boost.
void antialias_backward(Context& ctx, const Mesh& mesh, const Topology& topology, const AntialiasState& state,
                        Address color, std::int64_t channels, int height, int width, Address rast,
                        Address grad_out, Address grad_color, Address grad_pos, double pos_gradient_boost,
                        int threads);

}  // namespace gr::python
