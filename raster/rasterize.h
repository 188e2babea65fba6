// Rasterization into a coverage image, on plain arrays (no tape). The
// differentiable values (nvdiffrast's G-buffer) and their adjoint are made
// from its tri_id by raster/barycentric_gbuffer.h.
//
// Forward: clip-space triangles -> per pixel (tri_id, u, v, depth), where
// tri_id is 1-based (0 = background), (u, v) are the screen-space barycentrics
// of the pixel centre w.r.t. vertices 1 and 2 of the ORIGINAL triangle
// (u = E_20 / 2A, v = E_01 / 2A, b0 = 1 - u - v), and depth is z_ndc.
// Conventions, the tie rule, near/far clipping and the determinism scheme are
// described in docs/rasterizer.md.
#pragma once

#include <cstdint>
#include <memory>

namespace gr::raster {

namespace detail {
struct Vertices;  // raster/detail/rasterize_setup.h
}  // namespace detail

// Which faces to drop. Front face = counter-clockwise in NDC (OpenGL default),
// i.e. 2A > 0 in screen coordinates (y down).
enum class Cull { None, Back, Front };

struct RasterSettings {
  int width = 0;   // pixels, 1..16384
  int height = 0;  // pixels, 1..16384, width * height <= 2^28
  Cull cull = Cull::None;
  // Scan each tile's triangles nearest first (by their smallest vertex depth)
  // and skip triangles lying entirely behind everything the tile already
  // holds. Same output bit for bit (the (depth, id) key decides, not the
  // order); it only changes the amount of work (see docs/rasterizer.md).
  bool front_to_back = false;
  // Row 0 is the bottom row (nvdiffrast's and OpenGL's window convention): the
  // viewport is ys = H/2 (1 + y_ndc), so y_ndc = -1 is row 0's outer edge and
  // y_ndc = +1 the last row's. Precisely: every kernel computes on the clip
  // positions with y negated and returns the y gradient negated back, so the
  // result is bit for bit the y_up = false result on a y-negated copy of clip
  // (docs/rasterizer.md). `cull` judges the negated triangles, whose winding
  // the mirror reverses: with y_up, Cull::Back drops the faces that are
  // counter-clockwise in the caller's NDC, Cull::Front the clockwise ones.
  bool y_up = false;
};

// Triangle counts from one rasterize_forward call (each triangle lands in
// exactly one of the last six fields).
struct RasterStats {
  std::int64_t triangles_in = 0;      // triangles given
  std::int64_t culled_outside = 0;    // entirely outside one frustum plane (or w <= 0)
  std::int64_t culled_zero_area = 0;  // zero (homogeneous) area
  std::int64_t culled_face = 0;       // removed by the Cull setting
  std::int64_t culled_no_pixel = 0;   // box contains no pixel centre, or (box of <= 4 centres) covers none
  std::int64_t rasterized = 0;        // scanned (binned, or small-box fragments), all vertices in front of the near plane
  std::int64_t clipped_near = 0;      // binned and scanned, crossing the near plane / w = 0
};

// Depth written to background pixels (the far plane).
constexpr double kBackgroundDepth = 1.0;

// Inputs of one rasterize call, shared by the forward and the adjoint. The
// kernels trust them (the op validates, ops/check.h): the image size within
// RasterSettings' limits, every index in [0, num_vertices), clip finite.
template <class T>
struct RasterParams {
  const T* clip = nullptr;  // num_vertices x 4 row-major (x, y, z, w)
  std::int64_t num_vertices = 0;
  const std::int32_t* tris = nullptr;  // num_tris x 3 vertex indices
  std::int64_t num_tris = 0;
  RasterSettings settings;
  // Depth peeling (optional, both or neither; H*W each): a lower bound on the
  // (depth, id) key per pixel, the previous layer's key. A pixel keeps only
  // triangles whose key is strictly greater; floor_id is 1-based like tri_id
  // and 0 (background) leaves the pixel empty. floor_z is the exact (double)
  // depth the previous call wrote to key_depth.
  const std::int32_t* floor_id = nullptr;
  const double* floor_z = nullptr;
};

// Writes tri_id (H*W), uv (H*W*2, interleaved u, v), depth (H*W); row-major,
// row 0 at the top (at the bottom with settings.y_up). Background: tri_id 0, uv (0, 0), depth kBackgroundDepth.
// key_depth (optional, H*W): the winning depth in double, unrounded (for the
// next peeling layer's floor_z); background pixels get +inf.
// uv and depth may both be null: coverage only (tri_id, and key_depth), for
// callers that make the values from tri_id (raster/barycentric_gbuffer.h).
// projected (optional): gets the call's per-vertex projection of p.clip at
// settings' width, height and y_up, which antialias_forward on the same clip
// and image size takes instead of projecting again (AntialiasParams::projected).
template <class T>
void rasterize_forward(const RasterParams<T>& p, std::int32_t* tri_id, T* uv, T* depth,
                       RasterStats* stats = nullptr, double* key_depth = nullptr,
                       std::shared_ptr<const detail::Vertices>* projected = nullptr);

}  // namespace gr::raster
