// Depth peeling: successive depth layers of one triangle set, each an
// ordinary G-buffer differentiable like rasterize's.
//
// Layer k holds, per pixel, the nearest surface strictly behind layer k-1's
// in the rasterizer's (depth, triangle id) order, so coplanar faces and
// duplicates each appear in exactly one layer. Layer 1 is bit-identical to
// rasterize(). The kernel takes the previous layer's key as a per-pixel lower
// bound (raster::RasterParams::floor_id / floor_z): triangles are binned once
// per layer as in rasterize, no per-layer copies of the mesh. The keys and
// the per-image step are raster::DepthPeelState's (raster/depth_peel_state.h),
// which gradraster.torch's DepthPeeler shares. Once every
// pixel is exhausted, further layers are background everywhere.
//
// Batches peel like rasterize_batch / rasterize_ranges draw (ops/render/batch.h):
// every layer is a [B, H, W] G-buffer whose image b is bit-identical to
// peeling image b alone (in range mode with ids shifted by the range's
// first, as rasterize_ranges numbers them), for any thread count.
#pragma once

#include <cstdint>
#include <optional>

#include "ops/render/batch.h"
#include "ops/render/rasterize.h"
#include "raster/depth_peel_state.h"
#include "raster/image_batch.h"

namespace gr {

class DepthPeeler {
 public:
  // Same arguments and checks as rasterize(); the tensors are kept (not
  // copied), so later layers see the positions given here.
  DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options);

  // Instanced: clip [B, N, 4], triangles [M, 3]; the checks of rasterize_batch.
  static DepthPeeler instanced(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options);
  // Range mode: clip [N, 4], triangles [M, 3], ranges [B, 2] int32 (first,
  // count); the checks of rasterize_ranges. Layers' ids index the whole list.
  static DepthPeeler ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                            const RasterizeOptions& options);

  // The next layer, [H, W] as rasterize returns it ([B, H, W] as
  // rasterize_batch / rasterize_ranges for a batch); its uv and depth have
  // rasterize's adjoint w.r.t. clip (for that layer's fixed coverage).
  GBuffer rasterize_next_layer();

 private:
  DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
              raster::ImageBatch batch);

  Tensor clip_, triangles_;
  RasterizeOptions options_;
  std::optional<raster::ImageBatch> batch_;  // set for a batch
  // The previous layer's keys, copied (a caller may write to the returned G-buffer).
  raster::DepthPeelState peel_;
};

}  // namespace gr
