// Fragment mode: shading on the covered pixels only.
//
// fragments(gbuffer) lists the covered pixels of a G-buffer in row-major
// order; interpolate(..., fragments, ...) (ops/render/interpolate.h) and any tensor
// ops then work on [F, C] rows, and to_image puts the rows back into an
// [H, W, C] image over a background. Shading cost then follows coverage, not
// width x height, and the results equal the image-mode pipeline bit for bit
// on covered pixels. Gradients flow through every step: to_image's adjoint
// gathers the image gradient at the fragments, and the fragments' uv gather
// scatters its gradient back into gbuffer.uv, so rasterize's adjoint still
// gives dL/dclip.
//
//   GBuffer gb = rasterize(clip, tris, {W, H});
//   Fragments fr = fragments(gb);
//   Tensor colour = interpolate(colours, fr, tris);                    // [F, 3]
//   Tensor image = to_image(shade(colour), fr, background);            // [H, W, 3]
//   image = antialias(image, gb, clip, tris, aa);                      // as usual
#pragma once

#include "autodiff/base/tensor.h"
#include "ops/render/rasterize.h"

namespace gr {

struct Fragments {
  Tensor pixel_index;  // [F] int32: row-major ids (y * W + x) of the covered pixels, strictly ascending
  Tensor tri_id;       // [F] int32: 1-based triangle index (as GBuffer.tri_id; never 0)
  Tensor uv;           // [F, 2]: the pixels' barycentrics, gathered from gbuffer.uv (differentiable)
  int width = 0;
  int height = 0;
  std::int64_t count() const { return pixel_index.defined() ? pixel_index.size(0) : 0; }
};

// The covered pixels (tri_id != 0) of a G-buffer, compacted in parallel in a
// fixed, ascending order. uv = gather_fragments(gbuffer.uv, ...): dL/d(gbuffer.uv)
// gets the fragments' uv gradient at their pixels, zero elsewhere.
Fragments fragments(const GBuffer& gbuffer);

// image [H, W, C] float (H, W of the fragments) -> [F, C]: row f is the image
// at pixel_index[f]. dL/dimage = the rows of g at the fragments' pixels, 0 elsewhere.
// For per-pixel inputs of a shading function (e.g. a target or a view vector image).
Tensor gather_fragments(const Tensor& image, const Fragments& fragments);

// values [F, C] float -> [H, W, C]: covered pixels get their fragment's row,
// the others `background`: undefined (zeros), C values ([C]) or an image
// [H, W, C]; same dtype as values.
//   dL/dvalues[f] = g[pixel_index[f]];
//   dL/dbackground = sum of g over uncovered pixels ([C], fixed-order sum), or
//                    g with covered pixels zeroed ([H, W, C]).
Tensor to_image(const Tensor& values, const Fragments& fragments, const Tensor& background = Tensor());

}  // namespace gr
