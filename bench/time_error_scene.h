// The fixed scene of time_error (issue 6; docs/time_error.md): a coloured
// torus seen from 35 degrees above at 128 x 128, whose vertex positions and
// colours are the parameters; a target image of the same torus rotated and
// shifted; loss = MSE(render, target), rendered with a chosen dtype,
// antialiasing and supersampling.
#pragma once

#include <vector>

#include "autodiff/tensor.h"
#include "ops/antialias.h"

namespace gr::bench {

struct RenderSettings {
  DType dtype = DType::Float64;
  bool antialias = true;
  int supersample = 1;  // render at (s W) x (s H), then average s x s blocks (downsample_box)
  // > 0: soft_rasterize (ops/soft_rasterize.h) with this sigma (pixels^2) and
  // the scene's gamma and eps instead of rasterize + interpolate (+ antialias):
  // a blurred image, differentiable everywhere (docs/soft_rasterize.md).
  double soft_sigma = 0;
};

class TimeErrorScene {
 public:
  TimeErrorScene();

  int width() const { return kSize; }
  int height() const { return kSize; }
  std::int64_t num_points() const { return points_.size(0); }
  // Screen pixels per world unit at the torus centre (for choosing step sizes).
  double pixels_per_unit() const { return pixels_per_unit_; }

  // The parameters at which gradients are compared, [P, 3] float64 each.
  const Tensor& points() const { return points_; }
  const Tensor& colours() const { return colours_; }
  // Points of the target pose (the same torus, rotated and shifted), [P, 3] float64.
  const Tensor& target_points() const { return target_points_; }

  // The W x H x 3 image of the torus with the given points and colours (of the
  // settings' dtype), composited over the background; recorded on the tape
  // when they require grad.
  Tensor render(const Tensor& points, const Tensor& colours, const RenderSettings& settings) const;
  // mean((render - target)^2) over all pixels and channels (a rank-0 tensor).
  Tensor loss(const Tensor& points, const Tensor& colours, const Tensor& target, const RenderSettings& settings) const;

  // The render's inputs, also for other renderers (bench/exact_reference/):
  // clip positions [N, 4] and per-vertex colours [N, 3] of the render
  // vertices (recorded on the tape like render), their triangles [M, 3]
  // int32, the background [3] float64.
  Tensor clip_positions(const Tensor& points) const;
  Tensor vertex_colours(const Tensor& colours) const;
  const Tensor& triangles() const { return triangles_; }
  Tensor background() const;

 private:
  static constexpr int kSize = 128;
  Tensor points_, colours_, target_points_;  // welded torus points (the torus' seam copies share one point)
  Tensor render_index_;                      // [N] int32: render vertex -> point
  Tensor triangles_;                         // [M, 3] int32 over render vertices
  Tensor view_projection_;                   // [4, 4] float64
  AntialiasTopology topology_;
  double pixels_per_unit_ = 0;
};

}  // namespace gr::bench
