// Soft rasterization (SoftRas): every pixel blends the triangles near it,
// weighted by a sigmoid of the signed screen distance (sharpness sigma) and
// a softmax over depth (temperature gamma), so the image is a smooth
// function of the positions, and its gradient reaches triangles that do not
// cover the pixel. Formulas and bounds: raster/soft_rasterize.h and
// docs/soft_rasterize.md.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

struct SoftRasterizeOptions {
  int width = 0, height = 0;
  int max_faces = 8;  // triangles blended per pixel, the nearest ones (>= 1)
  double eps = 0.0;   // depth score of the background (0 = far plane, 1 = near plane)
};

// clip [N, 4], triangles [M, 3] int32, attributes [N, C], background [C]
// (the colour where no triangle reaches; zeros if undefined), sigma and gamma
// rank-0 tensors (pixels^2 and depth-score units, both > 0) -> [H, W, C].
// Differentiable w.r.t. clip, attributes, background, sigma and gamma.
// Throws ShapeError / DTypeError naming the argument for bad shapes or
// dtypes, ValueError for NaN/Inf inputs, sigma or gamma <= 0, max_faces < 1,
// a gamma so small that 1 / gamma or eps / gamma is infinite.
Tensor soft_rasterize(const Tensor& clip, const Tensor& triangles, const Tensor& attributes, const Tensor& sigma,
                      const Tensor& gamma, const SoftRasterizeOptions& options, const Tensor& background = {});

}  // namespace gr
