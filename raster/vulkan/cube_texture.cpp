// Cube-map sampling on a device: the checks and the shader inputs (the faces
// with their levels, face after face, or each face's level 0 alone when the
// device builds the levels; directions in the uv buffer, dir_da in uv_dx);
// the command buffers are internal/texture_call.h's.
#include "raster/vulkan/cube_texture.h"

#include <algorithm>
#include <limits>
#include <string>

#include "autodiff/base/error.h"
#include "raster/detail/rasterize_setup.h"  // detail::check_finite
#include "raster/vulkan/internal/texture_call.h"

namespace gr::vulkan {
namespace {

// Per-sample gradients the backward writes: d dir (3), d dir_da (6), d bias.
constexpr std::int64_t kSampleGrads = 10;
constexpr std::int64_t kMaxIndex = std::numeric_limits<std::int32_t>::max();

// Levels the filter reads: each face's layout for the mipmapped filters, else level 0.
int levels_read(const raster::CubeTextureParams<float>& p) {
  return raster::is_mipmapped(p.filter) ? p.layout.count() : 1;
}
std::int64_t base_texels(const raster::CubeTextureParams<float>& p) {
  return std::int64_t(p.layout.levels[0].width) * p.layout.levels[0].width;
}
std::int64_t face_texels(const raster::CubeTextureParams<float>& p) {
  return levels_read(p) == 1 ? base_texels(p) : p.layout.total_texels;
}

// The CPU kernel's checks (check_params, cube_texture_forward's), and the shaders' index range.
void check_params(const raster::CubeTextureParams<float>& p, const char* op) {
  if (p.layout.count() < 1 || p.layout.levels[0].width != p.layout.levels[0].height || p.channels < 1 ||
      p.num_samples < 0)
    throw ShapeError(std::string(op) + ": empty or non-square faces, or a negative sample count");
  if (!p.faces || (p.num_samples > 0 && !p.dir)) throw ValueError(std::string(op) + ": faces or dir missing");
  const bool mip = raster::is_mipmapped(p.filter);
  const std::int64_t values = 6 * face_texels(p) * p.channels;
  if (values > kMaxIndex || p.num_samples * std::max<std::int64_t>(p.channels, kSampleGrads) > kMaxIndex ||
      4 * p.num_samples > kMaxIndex)
    throw ValueError(std::string(op) + ": " + std::to_string(values) + " texel values and " +
                     std::to_string(p.num_samples) + " samples of " + std::to_string(p.channels) +
                     " channels: the GPU path takes at most " + std::to_string(kMaxIndex) +
                     " values and samples x channels, and " + std::to_string(kMaxIndex / 4) + " samples");
  raster::detail::check_finite(p.faces, 6 * base_texels(p) * p.channels, "tex", op);
  raster::detail::check_finite(p.dir, 3 * p.num_samples, "dir", op);
  if (mip) {
    if (p.dir_da) raster::detail::check_finite(p.dir_da, 6 * p.num_samples, "dir_da", op);
    if (p.mip_level_bias) raster::detail::check_finite(p.mip_level_bias, p.num_samples, "mip_level_bias", op);
  }
}

// raster::CubeFilter -> the shaders' filter numbers.
std::int32_t shader_filter(raster::CubeFilter f) {
  switch (f) {
    case raster::CubeFilter::Nearest: return kShaderNearest;
    case raster::CubeFilter::Bilinear: return kShaderBilinear;
    case raster::CubeFilter::LinearMipmapNearest: return kShaderLinearMipmapNearest;
    case raster::CubeFilter::Trilinear: return kShaderTrilinear;
  }
  return kShaderBilinear;
}

// The shaders' view of p: face f's level 0 then its levels 1.. (when read),
// for f = 0..5; the sample inputs the filter reads.
TextureCall call_of(const raster::CubeTextureParams<float>& p) {
  const bool mip = raster::is_mipmapped(p.filter);
  const std::size_t S = static_cast<std::size_t>(p.num_samples), C = static_cast<std::size_t>(p.channels);
  TextureCall c;
  c.cube = true;
  c.base_texels = base_texels(p);
  c.face_texels = face_texels(p);
  const std::size_t base = static_cast<std::size_t>(c.base_texels), upper = static_cast<std::size_t>(c.face_texels) - base;
  // Levels 1..: the caller's, else built on the device from each face's level 0.
  c.build_levels = upper && !p.pyramid;
  for (std::size_t f = 0; f < 6; ++f) {
    c.texels.push_back({p.faces + f * base * C, base * C * sizeof(float)});
    if (upper && !c.build_levels) c.texels.push_back({p.pyramid + f * upper * C, upper * C * sizeof(float)});
  }
  for (int l = 0; l < levels_read(p); ++l) {
    const raster::MipLevel& lv = p.layout.levels[l];
    c.levels.insert(c.levels.end(), {lv.height, lv.width, static_cast<std::int32_t>(lv.offset), 0});
  }
  c.uv = {p.dir, 3 * S * sizeof(float)};
  const bool da = mip && p.dir_da, bias = mip && p.mip_level_bias;
  if (da) c.uv_dx = {p.dir_da, 6 * S * sizeof(float)};
  if (bias) c.bias = {p.mip_level_bias, S * sizeof(float)};
  const std::int32_t flags = (da ? kHasDerivatives : 0) | (bias ? kHasBias : 0);
  // At most 4 contributions per texel value per sample: a level's 4 taps (3
  // at a corner) are distinct texels unless a face is 1 x 1.
  c.push = {static_cast<std::int32_t>(p.num_samples), static_cast<std::int32_t>(p.channels), levels_read(p),
            shader_filter(p.filter), 0, flags, 0, static_cast<std::int32_t>(4 * p.num_samples)};
  c.sample_grads = kSampleGrads;
  return c;
}

}  // namespace

GpuTimes cube_texture_forward(Device& device, const raster::CubeTextureParams<float>& p, float* out,
                              KeptTexels* kept) {
  check_params(p, "vulkan cube_texture");
  if (!out && p.num_samples > 0) throw ValueError("vulkan cube_texture: out is missing");
  return run_texture_forward(device, call_of(p), out, kept);
}

GpuTimes cube_texture_backward(Device& device, const raster::CubeTextureParams<float>& p, const float* grad_out,
                               const raster::CubeTextureGrads<float>& grads, KeptTexels* kept) {
  check_params(p, "vulkan cube_texture backward");
  if (!grad_out && p.num_samples > 0) throw ValueError("vulkan cube_texture backward: grad_out is missing");
  // What the CPU kernel writes (cube_texture_backward in raster/cube_texture.cpp).
  const bool trilinear = p.filter == raster::CubeFilter::Trilinear;
  float* want_dir = p.filter == raster::CubeFilter::Nearest ? nullptr : grads.dir;
  float* want_da = trilinear && p.dir_da ? grads.dir_da : nullptr;
  float* want_bias = trilinear ? grads.mip_level_bias : nullptr;
  const bool texels = grads.faces != nullptr, per_sample = want_dir || want_da || want_bias;
  if (!texels && !per_sample) return {};
  const std::int64_t face_values = 6 * base_texels(p) * p.channels;
  return run_texture_backward(device, call_of(p), grad_out, per_sample, texels,
                              [&](const float* got, const float* tex_grad) {
                                for (std::int64_t s = 0; got && s < p.num_samples; ++s) {
                                  const float* g = got + kSampleGrads * s;
                                  if (want_dir) add_to(want_dir + 3 * s, g, 3);
                                  if (want_da) add_to(want_da + 6 * s, g + 3, 6);
                                  if (want_bias) want_bias[s] += g[9];
                                }
                                if (tex_grad) add_to(grads.faces, tex_grad, face_values);
                              },
                              kept);
}

}  // namespace gr::vulkan
