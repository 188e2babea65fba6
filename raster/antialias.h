// Analytic silhouette antialiasing and its adjoint, on plain arrays (no tape).
//
// For every pair of horizontally or vertically neighbouring pixels whose
// triangle ids differ, the segment between the two centres is followed from
// the front triangle (smaller (depth, id) key; background is behind
// everything) across interior edges; if it crosses a silhouette edge before the
// other centre, and the pair's axis owns that edge, the crossing position t
// blends the two colours (a box filter across the edge). Horizontal pairs own
// edges closer to vertical (|dy| >= |dx| in screen space), vertical pairs
// those closer to horizontal (|dx| > |dy|), so each crossing is blended once,
// along the axis most perpendicular to it, and the blended value is the
// pixel's covered area to first order. Only pixels next to a tri_id change
// are visited.
// The adjoint goes to the colours of both pixels and, through t, to the screen
// positions of the edge's two vertices, then through the viewport and
// w-divide adjoints to the clip-space positions. Formulas, the silhouette
// criterion and the determinism scheme: docs/rasterizer.md, "Antialiasing".
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace gr::raster {

namespace detail {
struct Vertices;  // raster/detail/rasterize_setup.h
}  // namespace detail

// neighbour[] values for edges with no unique partner.
constexpr std::int64_t kBoundaryEdge = -1;     // no other triangle has this edge
constexpr std::int64_t kNonManifoldEdge = -2;  // three or more triangles (or a zero-length edge)

// Edge adjacency of a triangle list. Edge k of triangle t is the edge opposite
// vertex k (between vertices k+1 and k+2, mod 3), as in the rasterizer.
// neighbour()[3t + k] = 3n + k' for the one other triangle n that has the same
// undirected edge (k' = n's slot opposite that edge), or kBoundaryEdge /
// kNonManifoldEdge. Vertices are compared by index, or, when weld positions
// are given, vertices with equal position rows count as one vertex (so meshes
// with duplicated seam vertices are still closed).
//
// Immutable once made: its content can only be read, so its serial names it.
// The serial is unique in the process, given when it is made (never 0; a
// default-made one, empty, has 0); copies keep it (the same content), a
// moved-from one is left empty with serial 0. A device that keeps a copy of
// the adjacency (vulkan::Frame::antialias) reuses it while the serial is the
// same: a different adjacency is a new EdgeTopology, and so uploaded.
class EdgeTopology {
 public:
  EdgeTopology() = default;
  // Takes neighbour (3 num_tris entries, as above) and gives it a new serial.
  // Throws ValueError for another entry count and IndexError for an entry
  // that is neither a slot in [0, 3 num_tris) nor kBoundaryEdge /
  // kNonManifoldEdge (the kernels index triangles with them).
  EdgeTopology(std::int64_t num_tris, std::vector<std::int64_t> neighbour);
  EdgeTopology(const EdgeTopology&) = default;
  EdgeTopology& operator=(const EdgeTopology&) = default;
  EdgeTopology(EdgeTopology&& other) noexcept;
  EdgeTopology& operator=(EdgeTopology&& other) noexcept;

  std::int64_t num_tris() const { return num_tris_; }
  const std::vector<std::int64_t>& neighbour() const { return neighbour_; }  // 3 * num_tris
  std::uint64_t serial() const { return serial_; }

 private:
  std::int64_t num_tris_ = 0;
  std::vector<std::int64_t> neighbour_;
  std::uint64_t serial_ = 0;
};

// tris: M x 3 int32, each index in [0, num_vertices) (not checked here).
// weld_positions: num_vertices x dims row-major, finite, or null (no welding).
template <class T>
EdgeTopology build_edge_topology(const std::int32_t* tris, std::int64_t num_tris, std::int64_t num_vertices,
                                 const T* weld_positions, int dims);
EdgeTopology build_edge_topology(const std::int32_t* tris, std::int64_t num_tris, std::int64_t num_vertices);
// The vertex count implied by the indices (each >= 0, not checked here). The
// tables are sized by the vertices the triangles use, never by the largest
// index: sparse indices are renumbered densely, in order, first (which changes
// nothing in the result). edge_topology_bytes(num_tris) bounds what it takes.
EdgeTopology build_edge_topology(const std::int32_t* tris, std::int64_t num_tris);
std::size_t edge_topology_bytes(std::int64_t num_tris);

// One blended pixel pair, in the order the forward applied them (row-major by
// the pair's top/left pixel, then horizontal before vertical).
struct AntialiasPair {
  std::int64_t inside;   // pixel covered by the front triangle (row-major index)
  std::int64_t outside;  // its neighbour, on the far side of the silhouette edge
  std::int32_t a, b;     // vertex indices of the silhouette edge
  double t;              // crossing position along inside -> outside centre, in [0, 1)
};

struct AntialiasStats {
  std::int64_t candidate_pairs = 0;  // neighbouring pixels with different tri_id
  std::int64_t blended_pairs = 0;    // of those, crossed by a silhouette edge their axis owns
};

// Inputs of one antialias call, shared by the forward and the adjoint (which
// reads only image, channels, width, height, clip, num_vertices and y_up). The
// kernels trust them (the op validates, ops/check.h): tri_id and depth are
// the G-buffer of rasterize_forward on the same clip, tris, width, height;
// clip is finite; the topology was built for these triangles.
template <class T>
struct AntialiasParams {
  const T* image = nullptr;  // height x width x channels row-major
  int channels = 0;
  int width = 0, height = 0;
  const std::int32_t* tri_id = nullptr;  // height x width
  const T* depth = nullptr;              // height x width
  const T* clip = nullptr;               // num_vertices x 4
  std::int64_t num_vertices = 0;
  const std::int32_t* tris = nullptr;  // num_tris x 3
  std::int64_t num_tris = 0;
  const EdgeTopology* topology = nullptr;
  // Row 0 is the bottom row (RasterSettings::y_up; the G-buffer must come from
  // a y_up rasterize): the kernels read clip y negated and return the y
  // gradient negated, bit for bit the y_up = false result on a y-negated clip.
  bool y_up = false;
  // For a RasterBackend's antialias calls (raster/backend.h) only: run
  // visibility_antialias (raster/visibility_antialias.h) instead. The CPU
  // kernels ignore it (blend_boundaries_forward takes the choice itself).
  bool visibility = false;
  // The projection rasterize_forward made of clip at width x height and
  // y_up (its `projected`), or null: antialias_forward projects clip itself.
  const detail::Vertices* projected = nullptr;
};

// out: H x W x C row-major (may not alias image). For each blended pair (a
// silhouette edge a-b crossed between the centres; horizontal pairs only when
// |dy| >= |dx| of a-b, vertical pairs only when |dx| > |dy|), with t the
// crossing position:
//   t > 1/2: out[outside] += (t - 1/2) (image[inside] - image[outside])
//   t <= 1/2: out[inside] += (1/2 - t) (image[outside] - image[inside])
// (every other pixel is copied). Pairs are appended to *pairs if non-null
// (the backward needs them).
template <class T>
void antialias_forward(const AntialiasParams<T>& p, T* out, std::vector<AntialiasPair>* pairs = nullptr,
                       AntialiasStats* stats = nullptr);

// Where an adjoint accumulates: dL/dimage (H x W x C) and dL/dclip (N x 4);
// either may be null (not needed).
template <class T>
struct AntialiasGrads {
  T* image = nullptr;
  T* clip = nullptr;
};

// Adjoint of antialias_forward, ACCUMULATED (+=) into `grads`. With g =
// grad_out, per pair (target = the pixel written, source = the other,
// w = |t - 1/2|):
//   dL/dimage += g;  dL/dimage[target] -= w g[target];  dL/dimage[source] += w g[target]
//   dL/dt = g[target] . (image[inside] - image[outside])
//   t = E_i / (E_i - E_o), E_* = E(centre; a, b) (screen edge function):
//   dt/dE_i = -E_o / D^2, dt/dE_o = E_i / D^2, D = E_i - E_o (guarded)
//   dE/dax = qy - by, dE/day = bx - qx, dE/dbx = ay - qy, dE/dby = qx - ax
// then viewport_backward and wdivide_backward per vertex. Contributions are
// added in pair order: bit-identical for any thread count.
template <class T>
void antialias_backward(const AntialiasParams<T>& p, const std::vector<AntialiasPair>& pairs, const T* grad_out,
                        const AntialiasGrads<T>& grads);

}  // namespace gr::raster
