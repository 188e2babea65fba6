// texture in nvdiffrast's layout: [images, H, W, C] textures (or one texture
// broadcast over the minibatch) sampled at [images, h, w, 2] uv, with
// nvdiffrast's row convention (texel row = v H), its mip chain and its
// level-of-detail rule (the footprint ellipse's major axis).
#pragma once

#include <utility>
#include <vector>

#include "python/src/common.h"

namespace gr::python {

struct TextureArgs {
  bool f64 = false;
  Address tex = 0;              // [tex_images, height, width, channels]
  std::int64_t tex_images = 1;  // 1 = broadcast over the minibatch
  int height = 0, width = 0;
  std::int64_t channels = 0;
  // Levels 1.. per texture image ([tex_images, texels of levels 1.., channels]),
  // or 0 when the filter reads level 0 only; user = the caller's own stack.
  Address pyramid = 0;
  int levels = 1;  // levels used, base included
  bool user = false;
  Address uv = 0, uv_dx = 0, uv_dy = 0, bias = 0;  // [images, samples, 2 | 2 | 2 | 1]
  std::int64_t images = 0, samples = 0;
  int filter = 1;  // raster::Filter: 0 nearest, 1 bilinear, 2 trilinear, 3 linear-mipmap-nearest
  int wrap = 0;    // raster::Wrap: 0 repeat, 1 clamp, 2 mirror, 3 zero
  // Cube maps (boundary_mode 'cube'): tex is [tex_images, 6, S, S, C]
  // (height = width = S), uv holds directions [images, samples, 3], uv_da
  // nvdiffrast's [images, samples, 6] direction derivatives (0: the LOD is
  // the bias alone); pyramid per face (raster/cube_texture.h).
  bool cube = false;
  Address uv_da = 0;
  // Bilinear, not cube: d out/d(u, v) per sample, [images, samples, 2, channels],
  // written by texture_forward and read by texture_backward (0: not kept).
  Address uv_jacobian = 0;
};

// (height, width) of each mip level of a height x width texture, base first,
// down to 1 x 1 or to max_level (-1 = all).
std::vector<std::pair<int, int>> mip_sizes(int height, int width, int max_level);
// Writes levels 1..levels-1 of every texture image into pyramid (box filter).
void mip_build(const TextureArgs& a, int threads);

void texture_forward(const TextureArgs& a, Address out, int threads);
// Accumulates into the gradients that are not 0 (zeroed by the caller, shaped
// like their inputs; grad_pyramid only for a user stack). For a cube map,
// grad_uv_dx receives uv_da's gradient and grad_uv_dy is unused.
void texture_backward(const TextureArgs& a, Address grad_out, Address grad_tex, Address grad_uv, Address grad_uv_dx,
                      Address grad_uv_dy, Address grad_bias, Address grad_pyramid, int threads);

}  // namespace gr::python
