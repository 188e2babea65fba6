// Texture sampling and its adjoint on a Vulkan device: raster::texture_forward
// and texture_backward (raster/texture.h) for float32, every filter (nearest,
// bilinear, trilinear, linear-mipmap-nearest), wrap mode, LOD rule, v_down,
// per-sample mip_level_bias and the user's own mip levels. Cube maps:
// raster/vulkan/cube_texture.h.
//
// Results: the CPU kernel's taps in the same double expressions, so samples
// are the CPU's bit for bit for nearest and bilinear and within an ulp of
// float for the mipmapped filters (the LOD's log2 is the shader's own, within
// an ulp or two of the C library's and exact at powers of two). The texel
// gradients are summed in 64-bit fixed point (docs/gpu.md; resolution about
// 2^-59 x samples x the largest contribution), bit-identical run to run and
// for any workgroup size; with mip levels they then go down the pyramid
// through the box-filter adjoint in double, on the device.
//
// The pyramid (levels 1.., p.pyramid) is the caller's (raster::mip_build's,
// or the user's own levels), uploaded with the texture, or with p.pyramid
// null (not the user's) made on the device from level 0 by mip_build's box
// filter, bit for bit (texture_mip.comp); either unless the device keeps the
// texels (KeptTexels). Calls on one device are
// serialized.
#pragma once

#include <cstddef>
#include <cstdint>

#include "raster/texture.h"
#include "raster/vulkan/device.h"

namespace gr::vulkan {

// The texels a call reads (level 0 and the levels read, every face) kept on
// the device between calls: each device keeps up to kKeptTextures copies of
// kKeptTextureBytes in all, least recently used let go first (a larger one
// is uploaded at every call). serial, in: an earlier call's copy whose
// texels the caller vouches p's still are (same arrays, unwritten since; the
// ops check: ops/render/resident_texture.h), or 0; out: the copy this call
// read, now kept (0: none kept). A copy the device no longer keeps, or of
// another size or levels, means an upload: results never depend on it.
struct KeptTexels {
  std::uint64_t serial = 0;
};
constexpr int kKeptTextures = 8;
constexpr std::size_t kKeptTextureBytes = std::size_t(512) << 20;

// What a device's texture calls did with the texels so far (tests, profiling).
struct TextureResidency {
  std::int64_t uploads = 0;         // calls that uploaded their texels
  std::int64_t upload_bytes = 0;    // the texel bytes they uploaded
  std::int64_t resident_calls = 0;  // calls that read a kept copy: no upload
  int kept = 0;                     // copies kept now
  std::size_t kept_bytes = 0;       // their bytes
};
TextureResidency texture_residency(Device& device);

// raster::texture_forward(p, out) on the device. Checks p as the CPU kernel
// does (ValueError / ShapeError naming the problem: NaN or Inf in tex, uv,
// uv_dx, uv_dy, mip_level_bias; trilinear without derivatives or pyramid) and
// what the shaders' 32-bit indices allow (all levels' values and samples x
// channels below 2^31 - 2^24, samples below a quarter of that). pass_ms: sampling.
// kept: KeptTexels (null: uploaded, not kept).
GpuTimes texture_forward(Device& device, const raster::TextureParams<float>& p, float* out,
                         KeptTexels* kept = nullptr);

// raster::texture_backward(p, grad_out, grads) on the device: ACCUMULATED
// (+=) into each non-null pointer of grads, as on the CPU (nearest: none to
// uv; uv_dx, uv_dy, mip_level_bias through trilinear's LOD only; grads.pyramid
// only with p.user_pyramid). pass_ms: per-sample gradients and magnitudes,
// texel sums, finish (fixed point to double, the box-filter adjoint, to float).
GpuTimes texture_backward(Device& device, const raster::TextureParams<float>& p, const float* grad_out,
                          const raster::TextureGrads<float>& grads, KeptTexels* kept = nullptr);

}  // namespace gr::vulkan
