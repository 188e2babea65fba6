// Rasterization as an op: clip-space triangles -> G-buffer, differentiable
// with respect to the clip-space positions through the barycentrics and depth.
//
// The op takes clip-space positions (not screen positions) because clipping
// against the near plane must happen before the w-divide; internally it runs
// the same w-divide and viewport kernels as wdivide()/viewport(), and its
// adjoint chains through their adjoints (docs/decisions.md).
#pragma once

#include <memory>

#include "autodiff/base/tensor.h"
#include "ops/render/tensor_stamp.h"
#include "raster/backend.h"
#include "raster/rasterize.h"

namespace gr::raster {
class TriangleGroups;  // raster/detail/triangle_groups.h
}  // namespace gr::raster

namespace gr {

using raster::Cull;
struct ResidentGBuffer;  // ops/render/resident_gbuffer.h
namespace detail {
struct ClipProjection;  // below
}  // namespace detail

struct RasterizeOptions {
  int width = 0;
  int height = 0;
  Cull cull = Cull::None;  // front face = counter-clockwise in NDC
  bool front_to_back = false;  // work order only; same G-buffer (raster::RasterSettings)
  // Where the G-buffer is made (null: the CPU), e.g.
  // gr::vulkan::raster_backend(device) for float32 clip positions: the same
  // tri_id, uv, depth and db bit for bit, downloaded once and also kept on
  // the device (GBuffer::resident). The G-buffer keeps the backend
  // (GBuffer::backend): its adjoint and the interpolate and antialias ops
  // reading it run there too (float32; values within 1e-6 and gradients
  // within 1e-5 of the CPU's, deterministic), reading the device's copy while
  // the backend keeps it. GBuffer::stats stays zero when a backend ran it.
  std::shared_ptr<const raster::RasterBackend> backend = nullptr;
  // Also make GBuffer::db, the barycentrics' screen derivatives (nvdiffrast's
  // rast_db), for interpolate's attribute derivatives.
  bool derivatives = false;
};

// Per-pixel results, row 0 at the top: nvdiffrast's G-buffer (rast = u, v,
// z/w, id; rast_db) with the id as int32 and the channels in their own
// tensors (raster/barycentric_gbuffer.h has the formulas).
struct GBuffer {
  Tensor tri_id;  // [H, W] int32: 1-based triangle index, 0 = background (no gradient)
  Tensor uv;      // [H, W, 2]: perspective-correct barycentrics (u, v) of vertices 0 and 1 (0 on background)
  Tensor depth;   // [H, W]: z/w = z_ndc (raster::kBackgroundDepth, the far plane, on background)
  Tensor db;      // [H, W, 4] (RasterizeOptions::derivatives): (du/dx, du/dy, dv/dx, dv/dy), y down the rows
  raster::RasterStats stats;
  // The clip positions and triangles it was rasterized from, set by every op
  // that makes a G-buffer. Ops that read it together with clip and triangles
  // refuse others (detail::check_gbuffer_source); interpolate checks the
  // attributes' rows against clip. Undefined in a hand-made GBuffer.
  Tensor clip;
  Tensor triangles;
  // Set when recorded (one image): the pixels' grouping by triangle, made by
  // the first adjoint that needs it and reused by the others over this
  // tri_id (raster/detail/triangle_groups.h).
  std::shared_ptr<raster::TriangleGroups> groups;
  // RasterizeOptions::backend of the rasterize that made it (null: the CPU):
  // the execution context of the rasterize adjoint and of the interpolate
  // (image form) and antialias ops that read this G-buffer (their batch forms
  // for a batch's, image by image), for float32.
  std::shared_ptr<const raster::RasterBackend> backend;
  // The backend's copy of this G-buffer on its device (null: none; a batch's:
  // one per image, ops/render/resident_gbuffer.h), which the
  // ops above read instead of uploading the tensors while these are the
  // tensors it was made with, not written in place since (else, and once the
  // backend has let it go, they upload them: results never depend on it).
  std::shared_ptr<const ResidentGBuffer> resident;
  // The CPU rasterizer's per-vertex projection of clip (null: none, e.g. made
  // on a backend or of a mesh of more than kKeptProjectionVertices), which
  // antialias reads instead of projecting clip again (detail::projection_of).
  std::shared_ptr<const detail::ClipProjection> projection;
  int width() const { return static_cast<int>(tri_id.size(1)); }
  int height() const { return static_cast<int>(tri_id.size(0)); }
};

// clip [N, 4] float32/float64, triangles [M, 3] int32. Coverage comes from
// raster::rasterize_forward, the values from raster::barycentric_gbuffer_forward
// (homogeneous, exact also for triangles crossing the near plane). uv, depth
// and db are differentiable w.r.t. clip for a fixed coverage
// (raster::barycentric_gbuffer_backward). Coverage itself (which pixel belongs
// to which triangle) gets no gradient here; the antialias op supplies
// silhouette gradients.
GBuffer rasterize(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options);

namespace detail {
// A G-buffer keeps its projection (58 bytes a vertex) up to this many vertices:
// projecting is a fixed cost of small meshes (issue 31); a large mesh's
// G-buffers would hold much memory for a small part of the work.
constexpr std::int64_t kKeptProjectionVertices = std::int64_t(1) << 16;
struct ClipProjection {
  TensorStamp clip;  // the tensor projected, as it was then
  int width = 0, height = 0;
  std::shared_ptr<const raster::detail::Vertices> vertices;
};
// gb's projection when it is of `clip` (the same tensor, unwritten since) at
// width x height, else null (antialias then projects clip itself: the same bits).
const raster::detail::Vertices* projection_of(const GBuffer& gb, const Tensor& clip, int width, int height);
// rasterize's argument checks (op names the caller in messages).
void check_rasterize_inputs(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                            const char* op);
// rasterize without the checks, with the optional peeling floor and exact
// depth output of raster::rasterize_forward (DepthPeeler's layers). The
// layer records the same adjoint as rasterize: it depends on tri_id only.
GBuffer rasterize_layer(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                        const std::int32_t* floor_id, const double* floor_z, double* key_depth);
// Overwrites gb.uv, gb.depth (and fills gb.db when defined) of images
// [B, H, W] (or one [H, W]) from gb.tri_id (ids indexing all of gb.triangles)
// and records their adjoint to gb.clip: [N, 4] shared by the images (their
// gradients added in image order) or [B, N, 4].
void finish_gbuffer(GBuffer& gb, const char* op);
// finish_gbuffer's second half: records the adjoint of gb's values.
void record_gbuffer_adjoint(GBuffer& gb, const char* op);
}  // namespace detail

}  // namespace gr
