// Internal to the Vulkan path: one texture lookup call (2D, raster/vulkan/texture.cpp,
// or a cube map, raster/vulkan/cube_texture.cpp) as the texture shaders see it,
// and the command buffers that run its forward and adjoint
// (texture_common.glsl, texture_forward.glsl, texture_backward.glsl,
// texture_finish.comp). Each call uploads its inputs (the texels unless the
// device keeps them: KeptTexels), runs the passes and downloads; the buffers
// are the device's, grown to the largest call.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "raster/vulkan/device.h"
#include "raster/vulkan/internal/kernels.h"
#include "raster/vulkan/texture.h"

namespace gr::vulkan {

// texture_common.glsl's push constants and flags.
struct TexturePush {
  std::int32_t num_samples, channels, levels, filter, wrap, flags, pass, contributions;
};
constexpr std::int32_t kVDown = 1, kMajorAxis = 2, kHasBias = 4, kLodGrads = 8, kTexelGrads = 16,
                       kHasDerivatives = 32;
// The shaders' filter numbers (raster::Filter's).
constexpr std::int32_t kShaderNearest = 0, kShaderBilinear = 1, kShaderTrilinear = 2, kShaderLinearMipmapNearest = 3;

// What one call reads and runs. The texel uploads are the levels read, face
// after face (a face's level 0, then its levels 1..); levels: (height, width,
// offset, 0) per level of one face; sample inputs: uv (or directions),
// uv_dx (or dir_da), uv_dy, bias.
struct TextureCall {
  struct Upload {
    const void* data;
    std::size_t bytes;
  };
  std::vector<Upload> texels;
  std::vector<std::int32_t> levels;
  Upload uv{}, uv_dx{}, uv_dy{}, bias{};
  TexturePush push{};
  bool cube = false;              // the cube shaders (6 faces), else the 2D ones (1)
  std::int64_t face_texels = 0;   // texels of one face's levels read
  std::int64_t base_texels = 0;   // texels of one face's level 0
  std::int64_t sample_grads = 0;  // per-sample gradients the adjoint writes (the shader's kSampleGrads)
  bool keep_levels = false;       // the adjoint keeps every level's own gradient (the user's levels)
  bool build_levels = false;      // texels holds each face's level 0 only: levels 1.. are made on the device (texture_mip.comp)

  int faces() const { return cube ? 6 : 1; }
};

// Runs the forward into out (num_samples x channels floats). Takes the device's mutex.
// kept (may be null): the call's texels kept on the device (texture.h's
// KeptTexels; the device's texel cache, texture_call.cpp).
GpuTimes run_texture_forward(Device& device, const TextureCall& call, float* out, KeptTexels* kept = nullptr);

// Runs the adjoint of the lookups with incoming gradient grad_out (num_samples
// x channels) and hands what it downloads to `take` (still under the device's
// mutex): sample_grads floats per sample (when per_sample; else null) and the
// texel gradients (when texels; else null): level 0 of every face one after
// the other, or with keep_levels every level read as uploaded.
GpuTimes run_texture_backward(Device& device, const TextureCall& call, const float* grad_out, bool per_sample,
                              bool texels, const std::function<void(const float*, const float*)>& take,
                              KeptTexels* kept = nullptr);

// dst[0, n) += src[0, n) when dst is given (the adjoints accumulate, as on the CPU).
inline void add_to(float* dst, const float* src, std::int64_t n) {
  if (dst)
    for (std::int64_t i = 0; i < n; ++i) dst[i] += src[i];
}

}  // namespace gr::vulkan
