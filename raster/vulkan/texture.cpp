// Texture sampling on a device: the 2D lookups' checks and shader inputs;
// the command buffers are internal/texture_call.h's.
#include "raster/vulkan/texture.h"

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/detail/rasterize_setup.h"  // detail::check_finite
#include "raster/vulkan/internal/texture_call.h"

namespace gr::vulkan {
namespace {

// Per-sample gradients the backward writes: du, dv, d uv_dx (2), d uv_dy (2), d bias.
constexpr std::int64_t kSampleGrads = 7;

// The largest index the shaders take (32-bit ints).
constexpr std::int64_t kMaxIndex = std::numeric_limits<std::int32_t>::max();

// Levels the filter reads: the layout's for the mipmapped filters, else level 0.
int levels_read(const raster::TextureParams<float>& p) { return raster::mipmapped(p.filter) ? p.layout.count() : 1; }
std::int64_t base_texels(const raster::TextureParams<float>& p) {
  return std::int64_t(p.layout.levels[0].height) * p.layout.levels[0].width;
}
// Texels of the levels the filter reads.
std::int64_t texels_read(const raster::TextureParams<float>& p) {
  return levels_read(p) == 1 ? base_texels(p) : p.layout.total_texels;
}

// The CPU kernel's checks (texture_forward), and the shaders' index range.
void check_params(const raster::TextureParams<float>& p, const char* op) {
  if (p.layout.count() < 1 || p.channels < 1 || p.num_samples < 0)
    throw ShapeError(std::string(op) + ": empty texture or negative sample count");
  if (!p.tex || (p.num_samples > 0 && !p.uv)) throw ValueError(std::string(op) + ": tex or uv missing");
  const bool mip = raster::mipmapped(p.filter);
  if (mip && (!p.uv_dx || !p.uv_dy))
    throw ValueError(std::string(op) + ": mipmapped filtering needs uv_dx and uv_dy");
  if (mip && p.layout.count() > 1 && !p.pyramid && p.user_pyramid)
    throw ValueError(std::string(op) + ": user_pyramid without the user's mip levels (pyramid)");
  const std::int64_t values = texels_read(p) * p.channels;
  if (values > kMaxIndex || p.num_samples * std::max<std::int64_t>(p.channels, kSampleGrads) > kMaxIndex ||
      4 * p.num_samples > kMaxIndex)
    throw ValueError(std::string(op) + ": " + std::to_string(values) + " texel values and " +
                     std::to_string(p.num_samples) + " samples of " + std::to_string(p.channels) +
                     " channels: the GPU path takes at most " + std::to_string(kMaxIndex) +
                     " values and samples x channels, and " + std::to_string(kMaxIndex / 4) + " samples");
  raster::detail::check_finite(p.tex, base_texels(p) * p.channels, "tex", op);
  raster::detail::check_finite(p.uv, 2 * p.num_samples, "uv", op);
  if (mip) {
    raster::detail::check_finite(p.uv_dx, 2 * p.num_samples, "uv_dx", op);
    raster::detail::check_finite(p.uv_dy, 2 * p.num_samples, "uv_dy", op);
    if (p.mip_level_bias) raster::detail::check_finite(p.mip_level_bias, p.num_samples, "mip_level_bias", op);
  }
}

// The shaders' view of p: level 0, then levels 1.. when read; the sample
// inputs the filter reads.
TextureCall call_of(const raster::TextureParams<float>& p) {
  const bool mip = raster::mipmapped(p.filter);
  const std::size_t S = static_cast<std::size_t>(p.num_samples);
  TextureCall c;
  c.base_texels = base_texels(p);
  c.face_texels = texels_read(p);
  c.texels = {{p.tex, static_cast<std::size_t>(c.base_texels * p.channels) * sizeof(float)}};
  // Levels 1..: the caller's, else built on the device from level 0.
  c.build_levels = mip && p.layout.count() > 1 && !p.pyramid;
  if (!c.build_levels)
    c.texels.push_back(
        {p.pyramid, static_cast<std::size_t>((c.face_texels - c.base_texels) * p.channels) * sizeof(float)});
  for (int l = 0; l < levels_read(p); ++l) {
    const raster::MipLevel& lv = p.layout.levels[l];
    c.levels.insert(c.levels.end(), {lv.height, lv.width, static_cast<std::int32_t>(lv.offset), 0});
  }
  c.uv = {p.uv, 2 * S * sizeof(float)};
  if (mip) {
    c.uv_dx = {p.uv_dx, 2 * S * sizeof(float)};
    c.uv_dy = {p.uv_dy, 2 * S * sizeof(float)};
    if (p.mip_level_bias) c.bias = {p.mip_level_bias, S * sizeof(float)};
  }
  const std::int32_t flags = (p.v_down ? kVDown : 0) | (p.lod_rule == raster::LodRule::MajorAxis ? kMajorAxis : 0) |
                             (mip && p.mip_level_bias ? kHasBias : 0);
  c.push = {static_cast<std::int32_t>(p.num_samples), static_cast<std::int32_t>(p.channels), levels_read(p),
            static_cast<std::int32_t>(p.filter), static_cast<std::int32_t>(p.wrap), flags, 0,
            static_cast<std::int32_t>(4 * p.num_samples)};
  c.sample_grads = kSampleGrads;
  c.keep_levels = mip && p.user_pyramid;
  return c;
}

}  // namespace

GpuTimes texture_forward(Device& device, const raster::TextureParams<float>& p, float* out, KeptTexels* kept) {
  check_params(p, "vulkan texture");
  if (!out && p.num_samples > 0) throw ValueError("vulkan texture: out is missing");
  return run_texture_forward(device, call_of(p), out, kept);
}

GpuTimes texture_backward(Device& device, const raster::TextureParams<float>& p, const float* grad_out,
                          const raster::TextureGrads<float>& grads, KeptTexels* kept) {
  check_params(p, "vulkan texture backward");
  if (!grad_out && p.num_samples > 0) throw ValueError("vulkan texture backward: grad_out is missing");
  // What the CPU kernel writes (wanted_grads in raster/texture.cpp).
  const bool trilinear = p.filter == raster::Filter::Trilinear;
  float* want_uv = p.filter == raster::Filter::Nearest ? nullptr : grads.uv;
  float* want_dx = trilinear ? grads.uv_dx : nullptr;
  float* want_dy = trilinear ? grads.uv_dy : nullptr;
  float* want_bias = trilinear ? grads.mip_level_bias : nullptr;
  float* want_pyramid = raster::mipmapped(p.filter) && p.user_pyramid ? grads.pyramid : nullptr;
  const bool lod = want_dx || want_dy || want_bias, texels = grads.tex || want_pyramid;
  const bool per_sample = want_uv || lod;
  if (!texels && !per_sample) return {};
  TextureCall call = call_of(p);
  call.push.flags |= lod ? kLodGrads : 0;
  const std::int64_t base_values = call.base_texels * p.channels;
  const std::int64_t converted = want_pyramid ? call.face_texels * p.channels : base_values;
  return run_texture_backward(device, call, grad_out, per_sample, texels, [&](const float* got, const float* tex_grad) {
    for (std::int64_t s = 0; got && s < p.num_samples; ++s) {
      const float* g = got + kSampleGrads * s;
      if (want_uv) add_to(want_uv + 2 * s, g, 2);
      if (want_dx) add_to(want_dx + 2 * s, g + 2, 2);
      if (want_dy) add_to(want_dy + 2 * s, g + 4, 2);
      if (want_bias) want_bias[s] += g[6];
    }
    if (tex_grad) {
      add_to(grads.tex, tex_grad, base_values);
      add_to(want_pyramid, tex_grad + base_values, converted - base_values);
    }
  }, kept);
}

}  // namespace gr::vulkan
