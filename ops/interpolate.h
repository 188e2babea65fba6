// Attribute interpolation over a G-buffer as an op: per-vertex attributes ->
// per-pixel attributes, perspective-correct (1/w) by default.
#pragma once

#include "autodiff/tensor.h"
#include "ops/fragments.h"
#include "ops/rasterize.h"

namespace gr {

struct InterpolateOptions {
  bool perspective = true;  // false: linear in screen space
  Tensor background;        // [C] value for background pixels; undefined = zeros
};

// attributes [N, C] and the G-buffer of rasterize(clip, triangles, ...) with
// its triangles -> [H, W, C], nvdiffrast's argument order (attr, rast, tri).
// The clip positions come from the G-buffer (GBuffer::clip), so they are the
// rasterized ones by construction. The form below, which takes clip too, is
// the same op; it refuses a clip or triangles other than the rasterized ones.
Tensor interpolate(const Tensor& attributes, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options = {});

// attributes [N, C], clip [N, 4] (its w column is the 1/w weight), the
// G-buffer of rasterize(clip, triangles, ...) -> [H, W, C].
// With lambda = (1-u-v, u, v), q_k = lambda_k / w_k, s = sum q_k:
//   A = sum q_k A_k / s (perspective), A = sum lambda_k A_k (linear).
// Adjoints to the attributes, to w (into clip's last column) and to u, v
// (hence through rasterize to the clip positions); raster/interpolate.h
// states the formulas. w thus receives gradient along two paths (here and
// through rasterize), which the tape adds. Near-clipped triangles (a vertex
// with w <= 0 or z < -w) take q_k = F_k / D from the clip positions and the
// pixel centre instead (equal in value, exact at w_k = 0), so their gradient
// goes to x, y, w of clip, not to u, v.
Tensor interpolate(const Tensor& attributes, const Tensor& clip, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options = {});

// Fragment form (ops/fragments.h): the same values and adjoints at the
// fragments only -> [F, C], row f = the image form's pixel pixel_index[f], bit
// for bit. The uv adjoint goes to fragments.uv and from there into
// gbuffer.uv's gradient. options.background must be undefined (use to_image's).
Tensor interpolate(const Tensor& attributes, const Tensor& clip, const Fragments& fragments, const Tensor& triangles,
                   const InterpolateOptions& options = {});

// Interpolated attributes together with their screen-space derivatives (like
// nvdiffrast's diff_attrs), e.g. d(uv)/dx, d(uv)/dy for mipmapped texturing.
struct InterpolatedWithDerivatives {
  Tensor values;  // [H, W, C], exactly interpolate(...), differentiable as usual
  Tensor d_dx;    // [H, W, C]: d(values)/dx, x to the right, per pixel
  Tensor d_dy;    // [H, W, C]: d(values)/dy, y DOWN (row order), per pixel
};

// interpolate() plus analytic per-pixel derivatives of every channel (zero on
// background pixels). The screen barycentrics are affine in screen space
// (constant dlambda_k/dx, dlambda_k/dy per triangle, from the homogeneous
// vertices, so triangles crossing the near plane are handled too); the
// perspective form adds the quotient rule dA/dx = sum_k (dq_k/dx)(A_k - A)/s
// with q_k = lambda_k / w_k (raster/interpolate.h). The derivatives are
// constants for the tape (no gradient flows through them); they are meant for
// uses that treat them as stop-gradient, such as a texture's level of detail.
InterpolatedWithDerivatives interpolate_with_derivatives(const Tensor& attributes, const Tensor& clip,
                                                         const GBuffer& gbuffer, const Tensor& triangles,
                                                         const InterpolateOptions& options = {});

}  // namespace gr
