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
// vertices_needed: the fewest vertices the indices allow (the largest + 1),
// so that a caller keeping the topology (gradraster.torch's KeptTopologies)
// checks a later call's vertex count without a pass over the indices.
struct Topology {
  raster::EdgeTopology edges;
  std::int64_t triangles = 0;
  std::int64_t vertices_needed = 0;
};
std::shared_ptr<Topology> build_topology(const pybind11::object& tri, std::int64_t vertices, const std::string& op);

// What the backward needs: per image, the blended pixel pairs (of
// visibility_antialias when `visibility`), or that the backend ran it (it
// recomputes the pairs in its adjoint), and the sizes they index.
struct AntialiasState {
  std::vector<raster::BlendedPairs> pairs;
  std::shared_ptr<const raster::RasterBackend> backend;
  std::vector<char> on_backend;  // per image
  // Per image on the backend: the pairs its device kept, which the adjoint reads (the forward's inputs).
  std::vector<std::shared_ptr<const raster::DeviceForward>> device_pairs;
  std::shared_ptr<const DeviceGBuffers> kept;  // the forward's (the adjoint's inputs are the forward's)
  std::int64_t height = 0, width = 0, channels = 0, vertices = 0, triangles = 0;
  bool visibility = false;
};

// pos, tri, ranges: a Mesh (range mode: one range per image of rast).
// color, out: [images, H, W, C] of pos's dtype, C >= 1; rast: the G-buffer
// [images, H, W, 4] for the mesh. visibility: visibility_antialias instead
// of antialias. ctx: scratch, and the device of a RasterizeVulkanContext,
// which runs either (float32), forward and
// adjoint (the backward then runs on the state's backend). kept (may be
// null): rasterize_forward's handles for this very rast, pos and tri,
// unchanged since: the device then reads its copy of an image that drew all
// of tri, forward and adjoint (a range's copy: it uploads, the topology
// indexes all of tri).
std::shared_ptr<AntialiasState> antialias_forward(Context& ctx, const pybind11::object& pos,
                                                  const pybind11::object& tri, Ranges ranges, const Topology& topology,
                                                  const pybind11::object& color, const pybind11::object& rast,
                                                  const pybind11::object& out, bool visibility, int threads,
                                                  std::shared_ptr<DeviceGBuffers> kept);
// The forward's inputs and state; grad_out: color's shape. Accumulates into
// grad_color (zeroed, color's shape, or None) and grad_pos (zeroed, pos's
// shape, or None); the position gradient is multiplied by pos_gradient_boost.
void antialias_backward(Context& ctx, const pybind11::object& pos, const pybind11::object& tri, Ranges ranges,
                        const Topology& topology, const AntialiasState& state, const pybind11::object& color,
                        const pybind11::object& rast, const pybind11::object& grad_out,
                        const pybind11::object& grad_color, const pybind11::object& grad_pos,
                        double pos_gradient_boost, int threads);

}  // namespace gr::python
