// Cube-map sampling and its adjoint on a Vulkan device: raster::cube_texture_forward
// and cube_texture_backward (raster/cube_texture.h) for float32, every filter
// (nearest, bilinear, linear-mipmap-nearest, trilinear), seamless across the
// faces' edges and corners as the CPU does it (cube_texel; at a corner the
// missing 4th tap is the mean of the other 3), the LOD from dir_da or the
// bias alone, a per-sample mip_level_bias, the per-face box-filtered levels.
//
// Results: the CPU kernel's taps in the same double expressions (the 2D
// lookups' shaders with the cube's taps, cube_taps.glsl), so samples are the
// CPU's bit for bit for nearest and bilinear and within an ulp of float for
// the mipmapped filters (the LOD's log2 is the shader's own). The texel
// gradients are summed in 64-bit fixed point as the 2D lookups' are
// (raster/vulkan/texture.h), bit-identical run to run, then go down each
// face's pyramid through the box-filter adjoint in double, on the device.
//
// The per-face pyramids (levels 1.., p.pyramid, raster::cube_mip_build) are
// the caller's, uploaded with the faces, or with p.pyramid null made on the
// device from each face's level 0 by cube_mip_build's box filter, bit for bit
// (texture_mip.comp); either unless the device keeps the texels (KeptTexels,
// raster/vulkan/texture.h: the 2D lookups' cache, which holds the 6 faces and
// their levels as one copy). Calls on one device are serialized.
#pragma once

#include "raster/cube_texture.h"
#include "raster/vulkan/device.h"
#include "raster/vulkan/texture.h"  // KeptTexels

namespace gr::vulkan {

// raster::cube_texture_forward(p, out) on the device. Checks p as the CPU
// kernel does (ShapeError for empty or non-square faces; ValueError naming the
// problem: NaN or Inf in tex, dir, dir_da, mip_level_bias; faces or dir
// missing) and what the shaders' 32-bit indices allow (6 faces' values of
// every level read and samples x channels below 2^31, samples below a
// quarter of that). pass_ms: sampling. kept: KeptTexels (null: uploaded,
// not kept).
GpuTimes cube_texture_forward(Device& device, const raster::CubeTextureParams<float>& p, float* out,
                              KeptTexels* kept = nullptr);

// raster::cube_texture_backward(p, grad_out, grads) on the device: ACCUMULATED
// (+=) into each non-null pointer of grads, as on the CPU (nearest: none to
// dir; dir_da and mip_level_bias through trilinear's LOD only). pass_ms:
// per-sample gradients and magnitudes, texel sums, finish (fixed point to
// double, each face's box-filter adjoint, to float).
GpuTimes cube_texture_backward(Device& device, const raster::CubeTextureParams<float>& p, const float* grad_out,
                               const raster::CubeTextureGrads<float>& grads, KeptTexels* kept = nullptr);

}  // namespace gr::vulkan
