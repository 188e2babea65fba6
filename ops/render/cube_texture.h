// Cube-map sampling as an op: a texture of 6 square faces [6, S, S, C] (+X,
// -X, +Y, -Y, +Z, -Z, OpenGL's orientation) looked up by a 3D direction per
// sample with nearest, bilinear (seamless across edges and corners) or
// mipmapped filtering. Differentiable w.r.t. the texels, the direction, and
// (trilinear) the direction's screen derivatives and the LOD bias.
#pragma once

#include <memory>

#include "autodiff/base/tensor.h"
#include "raster/backend.h"
#include "raster/cube_texture.h"

namespace gr {

using raster::CubeFilter;

struct CubeTextureOptions {
  CubeFilter filter = CubeFilter::Bilinear;  // Nearest | Bilinear | LinearMipmapNearest | Trilinear
  // Mipmapped filters: highest mip level used (0 = base only); -1 = the full chain to 1 x 1.
  int max_mip_level = -1;
  // Where the lookups and their adjoint run (null: the CPU), e.g.
  // gr::vulkan::raster_backend(device), for float32 (float64 stays on the
  // CPU): samples within an ulp of float of the CPU's, gradients within 1e-5
  // of the largest (docs/gpu.md). A backend that builds mip levels
  // (RasterBackend::builds_mip_levels) makes the per-face pyramids on its
  // device, else they are built on the CPU; the backend keeps the cube map on
  // its device across calls while tex is unchanged (ops/render/resident_texture.h).
  std::shared_ptr<const raster::RasterBackend> backend = nullptr;
};

// tex [6, S, S, C] float32/float64 (face f, row t S, column s S; the face table
// is in raster/cube_map.h and docs/cube_maps.md); dir [..., 3] of the same
// dtype, any length (the zero vector samples 0 and gets no gradient) ->
// [..., C]. Mipmapped filters need dir_da [..., 6] = (dx/dX, dx/dY, dy/dX,
// dy/dY, dz/dX, dz/dY) (nvdiffrast's cube-mode uv_da) and/or mip_level_bias
// [...] (dir's shape without its last axis); with the bias alone the LOD is
// the bias. The other filters ignore dir_da.
// Adjoints (raster/cube_texture.h states them in full), with taps t (texel_t,
// weight w_t, the corner rule and trilinear level weights included) and
// g = dL/d(out):
//   dL/d texel_t += w_t g (levels >= 1 then through each face's box-filter adjoint);
//   dL/d(dir) = (g . sum_t (dw_t/ds) texel_t) ds/d(dir) + (likewise t), the
//   quotient rule of s = (sc/|ma| + 1)/2; nearest: none.
// Trilinear also through the LOD where it is not clamped: dir_da, dir and
// mip_level_bias (dL/dbias = dL/dlod = g . (B_l0+1 - B_l0)).
// Throws ShapeError naming 'tex' unless tex is [6, S, S, C] with S, C >= 1,
// ShapeError / DTypeError naming dir, dir_da or mip_level_bias for bad shapes
// or dtypes, ValueError for a mipmapped filter with neither dir_da nor
// mip_level_bias, a bias without a mipmapped filter, and NaN/Inf in tex, dir,
// dir_da or mip_level_bias (naming the element: "dir[7] is NaN or Inf").
Tensor cube_texture(const Tensor& tex, const Tensor& dir, const CubeTextureOptions& options = {},
                    const Tensor& dir_da = {}, const Tensor& mip_level_bias = {});

}  // namespace gr
