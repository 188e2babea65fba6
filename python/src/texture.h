// texture in nvdiffrast's layout: [images, H, W, C] textures (or one texture
// broadcast over the minibatch) sampled at [images, h, w, 2] uv, with
// nvdiffrast's row convention (texel row = v H), its mip chain and its
// level-of-detail rule (the footprint ellipse's major axis).
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include "python/src/common.h"
#include "python/src/rasterize.h"
#include "raster/backend.h"

namespace gr::python {

// How a texture is looked up (plain values; the tensors are arguments of
// each call).
struct TextureMode {
  int levels = 1;  // levels used, base included (1..the chain's length)
  // levels 1.. are the caller's own stack (not cube), not mip_build's
  bool user = false;
  int filter = 1;  // raster::Filter: 0 nearest, 1 bilinear, 2 trilinear, 3 linear-mipmap-nearest
  int wrap = 0;    // raster::Wrap: 0 repeat, 1 clamp, 2 mirror, 3 zero
  // Cube maps (boundary_mode 'cube'): tex is [tex_images, 6, S, S, C], uv
  // holds directions [images, h, w, 3], uv_dx nvdiffrast's uv_da [images, h,
  // w, 6] (None: the LOD is the bias alone), uv_dy None; pyramid per face
  // (raster/cube_texture.h).
  bool cube = false;
  // levels 1.. (mip_build's, not the user's) are made where the lookups run,
  // from tex: no pyramid is given (float32 lookups on a device whose backend
  // builds mip levels, RasterBackend::builds_mip_levels, only)
  bool device_levels = false;
};

// The tensors of one call, viewed and checked against each other:
//   tex      [tex_images, H, W, C] (cube: [tex_images, 6, S, S, C]) float,
//            sides <= 32768
//   pyramid  levels 1.. per texture image, [tex_images, texels of levels
//            1.. (x 6 for a cube), C]; required when levels > 1 (unless
//            mode.device_levels), else None
//   uv       [images, h, w, 2] (cube: 3); tex_images 1 (broadcast) or images
//   uv_dx, uv_dy [images, h, w, 2] or None (cube: uv_dx [images, h, w, 6])
//   bias     [images, h, w] or None
//   uv_jacobian [images, h, w, 2, C] or None: bilinear, not cube, d out/d(u, v)
//            written by the forward and read by the backward
// Without uv (mip_build) only tex and pyramid are given.
struct TextureArgs;

// (height, width) of each mip level of a height x width texture, base first,
// down to 1 x 1 or to max_level (-1 = all).
std::vector<std::pair<int, int>> mip_sizes(int height, int width, int max_level);
// Writes levels 1..levels-1 of every texture image into pyramid (box filter).
void mip_build(const TextureMode& mode, const pybind11::object& tex, const pybind11::object& pyramid, int threads);

// The texels a device's texture_forward kept (raster::DeviceTexture), one
// handle per texture image (null where none was kept), opaque to Python:
// gradraster.torch hands them to the backward of the same call, whose saved
// tex and pyramid torch keeps unchanged (it refuses a backward after an
// in-place write into them), and to later calls on the same tex (and mip
// stack) while torch's version counters say they are unwritten
// (_resident.py's KeptTextures).
struct DeviceTextures {
  std::vector<std::shared_ptr<const raster::DeviceTexture>> images;
};

// ctx: None (the CPU kernels) or the context that made uv, whose device (a
// RasterizeVulkanContext's) then runs float32 lookups and their adjoint
// (2D and cube maps; uv_jacobian must be None: its adjoint reads the texels).
// out: [images, h, w, C]. kept: None, or an earlier call's handles for these
// very texels (the same tex and levels, unwritten since: the caller vouches),
// one per texture image. Returns the texels the device kept (null for the
// CPU, float64, or none kept).
std::shared_ptr<DeviceTextures> texture_forward(Context* ctx, const TextureMode& mode, const pybind11::object& tex,
                                                const pybind11::object& uv, const pybind11::object& uv_dx,
                                                const pybind11::object& uv_dy, const pybind11::object& bias,
                                                const pybind11::object& pyramid, const pybind11::object& out,
                                                const pybind11::object& uv_jacobian, int threads,
                                                const std::shared_ptr<DeviceTextures>& kept = nullptr);
// grad_out: out's shape. Accumulates into the gradients given (zeroed by the
// caller, shaped like their inputs; None when not needed; grad_pyramid only
// for a user stack). For a cube map, grad_uv_dx receives uv_da's gradient and
// grad_uv_dy is None.
void texture_backward(Context* ctx, const TextureMode& mode, const pybind11::object& tex, const pybind11::object& uv,
                      const pybind11::object& uv_dx, const pybind11::object& uv_dy, const pybind11::object& bias,
                      const pybind11::object& pyramid, const pybind11::object& uv_jacobian,
                      const pybind11::object& grad_out, const pybind11::object& grad_tex,
                      const pybind11::object& grad_uv, const pybind11::object& grad_uv_dx,
                      const pybind11::object& grad_uv_dy, const pybind11::object& grad_bias,
                      const pybind11::object& grad_pyramid, int threads,
                      const std::shared_ptr<DeviceTextures>& kept = nullptr);

}  // namespace gr::python
