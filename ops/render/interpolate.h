// Attribute interpolation over a G-buffer as an op: per-vertex attributes ->
// per-pixel attributes, nvdiffrast's interpolate. The G-buffer's (u, v) are
// already perspective-correct (ops/render/rasterize.h), so the blend is linear:
//   A = u A_0 + v A_1 + (1 - u - v) A_2
// (raster/barycentric_interpolate.h), and needs no clip positions.
#pragma once

#include <cstdint>
#include <vector>

#include "autodiff/base/tensor.h"
#include "ops/render/fragments.h"
#include "ops/render/rasterize.h"

namespace gr {

struct InterpolateOptions {
  Tensor background;  // [C] value for background pixels; undefined = zeros
  // interpolate_with_derivatives: the channels to differentiate (nvdiffrast's
  // diff_attrs); empty = all.
  std::vector<std::int32_t> diff_attrs;
};

// attributes [N, C] (N = rows of the rasterized clip), the G-buffer of
// rasterize(clip, triangles, ...) and its triangles -> [H, W, C], nvdiffrast's
// argument order (attr, rast, tri). Differentiable w.r.t. the attributes and
// gbuffer.uv (hence, through rasterize, clip):
//   dL/dA_k += b_k g,  dL/du += g . (A_0 - A_2),  dL/dv += g . (A_1 - A_2).
// Triangles other than the rasterized ones are refused.
Tensor interpolate(const Tensor& attributes, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options = {});

// Fragment form (ops/render/fragments.h): the same values and adjoints at the
// fragments only -> [F, C], row f = the image form's pixel pixel_index[f], bit
// for bit. The uv adjoint goes to fragments.uv and from there into
// gbuffer.uv's gradient. options.background must be undefined (use to_image's).
Tensor interpolate(const Tensor& attributes, const Fragments& fragments, const Tensor& triangles,
                   const InterpolateOptions& options = {});

// Interpolated attributes together with their screen-space derivatives
// (nvdiffrast's diff_attrs), e.g. d(uv)/dx, d(uv)/dy for mipmapped texturing.
struct InterpolatedWithDerivatives {
  Tensor values;  // [H, W, C], exactly interpolate(...)
  Tensor d_dx;    // [H, W, K]: d/dx of the K channels options.diff_attrs, x to the right, per pixel
  Tensor d_dy;    // [H, W, K]: d/dy, y DOWN the rows (row order), per pixel
};

// interpolate() plus the derivatives of the channels options.diff_attrs (all
// if empty), from the G-buffer's db (rasterize with options.derivatives):
//   dA/dx = du/dx (A_0 - A_2) + dv/dx (A_1 - A_2)   (likewise y),
// 0 on background pixels. All three outputs are differentiable w.r.t. the
// attributes, gbuffer.uv and gbuffer.db (hence clip).
InterpolatedWithDerivatives interpolate_with_derivatives(const Tensor& attributes, const GBuffer& gbuffer,
                                                         const Tensor& triangles,
                                                         const InterpolateOptions& options = {});

}  // namespace gr
