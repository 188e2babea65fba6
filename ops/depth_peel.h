// Depth peeling: successive depth layers of one triangle set, each an
// ordinary G-buffer differentiable like rasterize's.
//
// Layer k holds, per pixel, the nearest surface strictly behind layer k-1's
// in the rasterizer's (depth, triangle id) order, so coplanar faces and
// duplicates each appear in exactly one layer. Layer 1 is bit-identical to
// rasterize(). The kernel takes the previous layer's key as a per-pixel lower
// bound (raster::RasterParams::floor_id / floor_z): triangles are binned once
// per layer as in rasterize, no per-layer copies of the mesh. Once every
// pixel is exhausted, further layers are background everywhere.
#pragma once

#include <cstdint>
#include <vector>

#include "ops/rasterize.h"

namespace gr {

class DepthPeeler {
 public:
  // Same arguments and checks as rasterize(); the tensors are kept (not
  // copied), so later layers see the positions given here.
  DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options);

  // The next layer, [H, W] as rasterize returns it; its uv and depth have
  // rasterize's adjoint w.r.t. clip (for that layer's fixed coverage).
  GBuffer rasterize_next_layer();

 private:
  Tensor clip_, triangles_;
  RasterizeOptions options_;
  int layers_ = 0;
  // The previous layer's key, copied (a caller may write to the returned G-buffer).
  std::vector<std::int32_t> floor_id_;
  std::vector<double> floor_z_;
};

}  // namespace gr
