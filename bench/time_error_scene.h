// The scenes of time_error (issue 6, four of them since issue 13 item 4;
// docs/time_error.md), all seen from 35 degrees above at 128 x 128, whose
// welded vertex positions and colours are the parameters; a target image of
// the same scene with its objects rotated and shifted; loss = MSE(render,
// target), rendered with a chosen dtype, antialiasing and supersampling.
//   torus         one torus: silhouettes against the background
//   intersection  a sphere sunk half into a tilted square: an intersection curve
//   occlusion     a small sphere in front of a large one, partly covering it
//   open_culled   an open bowl (hemisphere) drawn with back faces culled
#pragma once

#include <string>
#include <vector>

#include "autodiff/base/tensor.h"
#include "ops/render/antialias.h"
#include "raster/rasterize.h"  // raster::Cull

namespace gr::bench {

struct RenderSettings {
  DType dtype = DType::Float64;
  bool antialias = true;
  int supersample = 1;  // render at (s W) x (s H), then average s x s blocks (downsample_box)
  // > 0: soft_rasterize (ops/render/soft_rasterize.h) with this sigma (pixels^2) and
  // the scene's gamma and eps instead of rasterize + interpolate (+ antialias):
  // a blurred image, differentiable everywhere (docs/soft_rasterize.md).
  double soft_sigma = 0;
  // With antialias: visibility_antialias (ops/render/visibility_antialias.h, every
  // visibility boundary including intersection curves) instead of antialias.
  bool visibility = false;
};

// The scene names TimeErrorScene accepts, in time_error's order.
const std::vector<std::string>& time_error_scene_names();

class TimeErrorScene {
 public:
  // One of time_error_scene_names(); throws ValueError otherwise.
  explicit TimeErrorScene(const std::string& name = "torus");

  const std::string& name() const { return name_; }
  const std::string& description() const { return description_; }  // one line, for the table's header
  // Culling of the render and of the exact reference (None but for open_culled).
  raster::Cull cull() const { return cull_; }
  int width() const { return kSize; }
  int height() const { return kSize; }
  std::int64_t num_points() const { return points_.size(0); }
  std::int64_t num_triangles() const { return triangles_.size(0); }
  // Screen pixels per world unit at the scene centre (for choosing step sizes).
  double pixels_per_unit() const { return pixels_per_unit_; }

  // The parameters at which gradients are compared, [P, 3] float64 each.
  const Tensor& points() const { return points_; }
  const Tensor& colours() const { return colours_; }
  // Points of the target pose (each object rotated and shifted), [P, 3] float64.
  const Tensor& target_points() const { return target_points_; }

  // The W x H x 3 image of the scene with the given points and colours (of the
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
  // The antialias topology of the render, welded by point.
  const AntialiasTopology& topology() const { return topology_; }
  // The objects of the scene (1 or 2) and the object of each point, [P] int32.
  int num_parts() const { return num_parts_; }
  const Tensor& point_part() const { return point_part_; }

 private:
  static constexpr int kSize = 128;
  std::string name_, description_;
  raster::Cull cull_ = raster::Cull::None;
  Tensor points_, colours_, target_points_;  // welded points (a mesh's seam copies share one point)
  Tensor render_index_;                      // [N] int32: render vertex -> point
  Tensor point_part_;                        // [P] int32: point -> object
  int num_parts_ = 1;
  Tensor triangles_;                         // [M, 3] int32 over render vertices
  Tensor view_projection_;                   // [4, 4] float64
  AntialiasTopology topology_;
  double pixels_per_unit_ = 0;
};

}  // namespace gr::bench
