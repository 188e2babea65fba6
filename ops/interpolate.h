// Attribute interpolation over a G-buffer as an op: per-vertex attributes ->
// per-pixel attributes, perspective-correct (1/w) by default.
#pragma once

#include "autodiff/tensor.h"
#include "ops/rasterize.h"

namespace gr {

struct InterpolateOptions {
  bool perspective = true;  // false: linear in screen space
  Tensor background;        // [C] value for background pixels; undefined = zeros
};

// attributes [N, C], clip [N, 4] (its w column is the 1/w weight), the
// G-buffer of rasterize(clip, triangles, ...) -> [H, W, C].
// With lambda = (1-u-v, u, v), q_k = lambda_k / w_k, s = sum q_k:
//   A = sum q_k A_k / s (perspective), A = sum lambda_k A_k (linear).
// Adjoints to the attributes, to w (into clip's last column) and to u, v
// (hence through rasterize to the clip positions); raster/interpolate.h
// states the formulas. w thus receives gradient along two paths (here and
// through rasterize), which the tape adds.
Tensor interpolate(const Tensor& attributes, const Tensor& clip, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options = {});

}  // namespace gr
