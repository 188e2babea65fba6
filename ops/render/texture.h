// Texture sampling as an op: an [Ht, Wt, C] texture (or one per image,
// [B, Ht, Wt, C]) looked up at per-pixel (u, v) with nearest, bilinear or
// mipmapped trilinear filtering and repeat / clamp / mirror addressing.
// Differentiable w.r.t. the texels (every mip level's gradient flows back to
// the base texture) and w.r.t. uv.
#pragma once

#include <vector>

#include <memory>

#include "autodiff/base/tensor.h"
#include "raster/backend.h"
#include "raster/texture.h"

namespace gr {

using raster::Filter;
using raster::LodRule;
using raster::Wrap;

struct TextureOptions {
  Filter filter = Filter::Bilinear;
  Wrap wrap = Wrap::Repeat;
  // Mipmapped filters: highest mip level used (0 = base only); -1 = the full chain to 1 x 1.
  int max_mip_level = -1;
  // How the footprint sets the level of detail (raster/texture.h): OpenGL's
  // isotropic rule or nvdiffrast's major axis.
  LodRule lod_rule = LodRule::Isotropic;
  // Where the lookups and their adjoint run (null: the CPU), e.g.
  // gr::vulkan::raster_backend(device), for float32 (float64 stays on the
  // CPU, as rasterize's): samples within an ulp of float of the CPU's,
  // gradients within 1e-5 of the largest (docs/gpu.md). The mip pyramid is
  // built on the CPU either way.
  std::shared_ptr<const raster::RasterBackend> backend = nullptr;
};

// tex [Ht, Wt, C] float32/float64 (row 0 = top of the image, as read_image
// returns it); uv [..., 2] of the same dtype (u right, v UP: texel x =
// u Wt - 0.5, y = (1 - v) Ht - 0.5) -> [..., C]. Trilinear needs uv_dx and
// uv_dy, the screen-space derivatives d(u, v)/dx and d(u, v)/dy per pixel
// (same shape as uv; e.g. from interpolate_with_derivatives); the other
// filters ignore them. docs/texture.md has the details.
// Adjoints, with taps t (texel_t, weight w_t) of a sample and g = dL/d(out):
//   dL/d texel_t += w_t g (levels >= 1 then through the box-filter adjoint:
//   each child texel's gradient to its parents / block size);
//   dL/du = g . sum_t (dw_t/du) texel_t with dx/du = W_l,
//   dL/dv = g . sum_t (dw_t/dv) texel_t with dy/dv = -H_l.
// Nearest gives no gradient to uv (piecewise constant).
// Trilinear: the level of detail is differentiable (raster/texture.h states the
// formula): uv_dx, uv_dy and mip_level_bias get gradients where the LOD is not
// clamped to [0, last level]. mip_level_bias (optional, trilinear only; uv's
// shape without its last axis, as nvdiffrast's) is added to the LOD per sample.
// mip (optional, trilinear only; nvdiffrast's `mip` argument): the user's own
// levels 1.. instead of the box-filtered pyramid, each [h_l, w_l, C] with the
// sizes of tex's mip chain (halving, max(1, floor(n / 2))) down to 1 x 1 or to
// max_mip_level levels; each level receives its own gradient (nothing flows
// from them to tex).
// A texture per image (nvdiffrast's tex [B, Ht, Wt, C]): a rank-4 tex with
// uv [B, ..., 2] looks image b's samples up in tex[b] (tex [1, Ht, Wt, C]:
// one texture for every image); uv_dx, uv_dy and mip_level_bias keep uv's
// shapes, mip levels take tex's leading axis ([B or 1, h_l, w_l, C]), and the
// box-filtered pyramid is built per texture. Images run in parallel; each
// image's values and gradients are bit-identical to a separate call on its
// slices for any thread count. A shared texture's (and mip stack's) gradient
// is the images' gradients summed in image order; its images' adjoints then
// run one after the other (each parallel inside).
// Throws ShapeError / DTypeError naming the argument for bad shapes or dtypes,
// ValueError for trilinear without derivatives, a bias or a mip stack without
// trilinear, and NaN/Inf in uv, uv_dx, uv_dy, mip_level_bias or a mip level;
// a tex batch that is neither 1 nor uv's is a ShapeError naming both.
Tensor texture(const Tensor& tex, const Tensor& uv, const TextureOptions& options = {}, const Tensor& uv_dx = {},
               const Tensor& uv_dy = {}, const Tensor& mip_level_bias = {}, const std::vector<Tensor>& mip = {});

}  // namespace gr
