// Rasterization as an op: clip-space triangles -> G-buffer, differentiable
// with respect to the clip-space positions through the barycentrics and depth.
//
// The op takes clip-space positions (not screen positions) because clipping
// against the near plane must happen before the w-divide; internally it runs
// the same w-divide and viewport kernels as wdivide()/viewport(), and its
// adjoint chains through their adjoints (docs/decisions.md).
#pragma once

#include <memory>

#include "autodiff/tensor.h"
#include "raster/backend.h"
#include "raster/rasterize.h"

namespace gr {

using raster::Cull;

struct RasterizeOptions {
  int width = 0;
  int height = 0;
  Cull cull = Cull::None;  // front face = counter-clockwise in NDC
  bool front_to_back = false;  // work order only; same G-buffer (raster::RasterSettings)
  // Where the forward runs (null: the CPU), e.g. gr::vulkan::raster_backend(device)
  // for float32 clip positions: the same G-buffer bit for bit, and the same
  // adjoint (on the CPU). GBuffer::stats stays zero when a backend ran it.
  std::shared_ptr<const raster::RasterBackend> backend = nullptr;
};

// Per-pixel results, row 0 at the top.
struct GBuffer {
  Tensor tri_id;  // [H, W] int32: 1-based triangle index, 0 = background (no gradient)
  Tensor uv;      // [H, W, 2]: screen-space barycentrics (u, v) of vertices 1 and 2
  Tensor depth;   // [H, W]: z_ndc (raster::kBackgroundDepth on background)
  raster::RasterStats stats;
  // The clip positions and triangles it was rasterized from, set by every op
  // that makes a G-buffer. Ops that read it together with clip and triangles
  // refuse others (detail::check_gbuffer_source), and interpolate(attributes,
  // gbuffer, triangles) takes clip from here. Undefined in a hand-made GBuffer.
  Tensor clip;
  Tensor triangles;
  // Set when recorded: the pixels' grouping by triangle, made by the first
  // adjoint that needs it and reused by the others (raster/triangle_groups.h).
  std::shared_ptr<raster::TriangleGroups> groups;
  int width() const { return static_cast<int>(tri_id.size(1)); }
  int height() const { return static_cast<int>(tri_id.size(0)); }
};

// clip [N, 4] float32/float64, triangles [M, 3] int32. uv and depth are
// differentiable w.r.t. clip for a fixed coverage: for u = E_20/2A, v = E_01/2A
// the adjoint is the quotient rule on the edge functions, then the viewport
// and w-divide adjoints (raster/rasterize.h states the formulas). Coverage
// itself (which pixel belongs to which triangle) gets no gradient here; the
// antialias op supplies silhouette gradients.
GBuffer rasterize(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options);

namespace detail {
// rasterize's argument checks (op names the caller in messages).
void check_rasterize_inputs(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                            const char* op);
// rasterize without the checks, with the optional peeling floor and exact
// depth output of raster::rasterize_forward (DepthPeeler's layers). The
// layer records the same adjoint as rasterize: it depends on tri_id only.
GBuffer rasterize_layer(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                        const std::int32_t* floor_id, const double* floor_z, double* key_depth);
}  // namespace detail

}  // namespace gr
