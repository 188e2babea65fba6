// Texture sampling on a device: each call uploads the texture (every level it
// reads), the samples' uv (and derivatives, bias), runs the passes and
// downloads what was asked, in one command buffer with timestamps between.
#include "raster/vulkan/texture.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/detail/rasterize_setup.h"  // detail::check_finite
#include "raster/vulkan/internal/buffer.h"
#include "raster/vulkan/internal/kernels.h"

namespace gr::vulkan {
namespace {

// texture_common.glsl's push constants and flags.
struct TexturePush {
  std::int32_t num_samples, channels, levels, filter, wrap, flags, pass, contributions;
};
constexpr std::int32_t kVDown = 1, kMajorAxis = 2, kHasBias = 4, kLodGrads = 8, kTexelGrads = 16;
// texture_finish.comp's.
struct TextureFinishPush {
  std::int32_t mode, count, channels, level, contributions, first, pad[2];
};
static_assert(sizeof(TexturePush) == kPushBytes && sizeof(TextureFinishPush) == kPushBytes, "push constant blocks");
// Per-sample gradients the backward writes: du, dv, d uv_dx (2), d uv_dy (2), d bias.
constexpr std::int64_t kSampleGrads = 7;

enum Role { kTexels, kLevels, kUv, kUvDx, kUvDy, kBias, kValues, kSums, kLargest, kSampleGradOut, kTexGrad, kRoles };

// The device's texture buffers (Device::Impl::texture_buffers), grown to the
// largest call and reused.
struct Buffers {
  Buffers(Device::Impl& dev, Kernels& k)
      : dev(dev), k(k), sample_set(dev, k.pipelines), finish_set(dev, k.pipelines), timestamps(dev, 6) {}
  Device::Impl& dev;
  Kernels& k;
  Buffer buffers[kRoles];
  Buffer upload, download;
  DescriptorSet sample_set, finish_set;
  Timestamps timestamps;

  Buffer& operator[](Role r) { return buffers[r]; }
  VkDescriptorSet bind(DescriptorSet& set, std::initializer_list<std::pair<std::uint32_t, Role>> bindings) {
    VkBuffer handles[kBindings] = {};
    for (const auto& [binding, role] : bindings) handles[binding] = buffers[role].handle();
    return set.bind(handles);
  }
  void use(VkCommandBuffer cb, VkDescriptorSet set) {
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, k.pipelines.layout(), 0, 1, &set, 0, nullptr);
  }
};

// The device's Buffers, made on first use. Call with the device's mutex held.
Buffers& buffers_of(Device::Impl& dev) {
  if (!dev.texture_buffers) dev.texture_buffers = std::make_shared<Buffers>(dev, kernels_of(dev));
  return *static_cast<Buffers*>(dev.texture_buffers.get());
}

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
  if (mip && p.layout.count() > 1 && !p.pyramid)
    throw ValueError(std::string(op) + ": mipmapped filtering needs the mip pyramid");
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

// Host arrays to device buffers through the upload staging buffer.
struct Upload {
  Role role;
  const void* data;
  std::size_t bytes;
};

// Reserves and fills the staging buffer and the sampling inputs' buffers:
// texels (level 0, then levels 1.. when read), levels, uv, uv_dx, uv_dy, bias.
std::vector<Upload> sampling_inputs(Buffers& b, const raster::TextureParams<float>& p,
                                    std::vector<std::int32_t>& levels) {
  const bool mip = raster::mipmapped(p.filter);
  const std::size_t S = static_cast<std::size_t>(p.num_samples);
  const std::size_t base_bytes = static_cast<std::size_t>(base_texels(p) * p.channels) * sizeof(float);
  const std::size_t upper_bytes = static_cast<std::size_t>((texels_read(p) - base_texels(p)) * p.channels) * sizeof(float);
  for (int l = 0; l < levels_read(p); ++l) {
    const raster::MipLevel& lv = p.layout.levels[l];
    levels.insert(levels.end(), {lv.height, lv.width, static_cast<std::int32_t>(lv.offset), 0});
  }
  std::vector<Upload> up{{kTexels, p.tex, base_bytes},
                         {kTexels, p.pyramid, upper_bytes},
                         {kLevels, levels.data(), levels.size() * sizeof(std::int32_t)},
                         {kUv, p.uv, 2 * S * sizeof(float)},
                         {kUvDx, mip ? p.uv_dx : nullptr, mip ? 2 * S * sizeof(float) : 0},
                         {kUvDy, mip ? p.uv_dy : nullptr, mip ? 2 * S * sizeof(float) : 0},
                         {kBias, mip ? p.mip_level_bias : nullptr, mip && p.mip_level_bias ? S * sizeof(float) : 0}};
  b[kTexels].reserve(b.dev, base_bytes + upper_bytes, false);
  for (std::size_t i = 2; i < up.size(); ++i) b[up[i].role].reserve(b.dev, up[i].bytes, false);
  return up;
}

// Copies `uploads` into the staging buffer (reserved for them and `extra` bytes
// after them); returns the staging offset of the extra bytes.
std::size_t stage(Buffers& b, const std::vector<Upload>& uploads, std::size_t extra) {
  std::size_t total = extra;
  for (const Upload& u : uploads) total += u.bytes;
  b.upload.reserve(b.dev, total, true);
  std::size_t offset = 0;
  for (const Upload& u : uploads) {
    if (u.bytes) std::memcpy(static_cast<char*>(b.upload.mapped()) + offset, u.data, u.bytes);
    offset += u.bytes;
  }
  return offset;
}

// Records the staged uploads (the texels' two parts one after the other).
void record_uploads(VkCommandBuffer cb, Buffers& b, const std::vector<Upload>& uploads) {
  std::size_t from = 0, texel_offset = 0;
  for (const Upload& u : uploads) {
    const std::size_t to = u.role == kTexels ? texel_offset : 0;
    copy(cb, b.upload.handle(), from, b[u.role].handle(), to, u.bytes);
    if (u.role == kTexels) texel_offset += u.bytes;
    from += u.bytes;
  }
}

TexturePush push_of(const raster::TextureParams<float>& p) {
  const std::int32_t flags = (p.v_down ? kVDown : 0) | (p.lod_rule == raster::LodRule::MajorAxis ? kMajorAxis : 0) |
                             (raster::mipmapped(p.filter) && p.mip_level_bias ? kHasBias : 0);
  return {static_cast<std::int32_t>(p.num_samples), static_cast<std::int32_t>(p.channels), levels_read(p),
          static_cast<std::int32_t>(p.filter), static_cast<std::int32_t>(p.wrap), flags, 0,
          static_cast<std::int32_t>(4 * p.num_samples)};
}

// dst[0, n) += src[0, n) when dst is given (the adjoint accumulates, as on the CPU).
void add_to(float* dst, const float* src, std::int64_t n) {
  if (dst)
    for (std::int64_t i = 0; i < n; ++i) dst[i] += src[i];
}

}  // namespace

GpuTimes texture_forward(Device& device, const raster::TextureParams<float>& p, float* out) {
  check_params(p, "vulkan texture");
  if (!out && p.num_samples > 0) throw ValueError("vulkan texture: out is missing");
  Device::Impl& dev = device.impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  Buffers& b = buffers_of(dev);
  std::vector<std::int32_t> levels;
  const std::vector<Upload> uploads = sampling_inputs(b, p, levels);
  const std::size_t out_bytes = static_cast<std::size_t>(p.num_samples * p.channels) * sizeof(float);
  b[kValues].reserve(dev, out_bytes, false);
  b.download.reserve(dev, out_bytes, true);
  stage(b, uploads, 0);
  // Bindings (texture_common.glsl): 0 texels, 1 levels, 2 uv, 3 uv_dx, 4 uv_dy, 5 bias, 6 out.
  const VkDescriptorSet set = b.bind(b.sample_set, {{0, kTexels}, {1, kLevels}, {2, kUv}, {3, kUvDx}, {4, kUvDy},
                                                    {5, kBias}, {6, kValues}});
  const TexturePush push = push_of(p);
  dev.run([&](VkCommandBuffer cb) {
    b.timestamps.begin(cb, 4);
    record_uploads(cb, b, uploads);
    barrier(cb);
    b.timestamps.stamp(cb, 1);
    b.use(cb, set);
    dispatch(cb, b.k, b.k.texture_forward, &push, p.num_samples, 256);
    barrier(cb);
    b.timestamps.stamp(cb, 2);
    copy(cb, b[kValues].handle(), 0, b.download.handle(), 0, out_bytes);
    barrier(cb);
    b.timestamps.stamp(cb, 3);
  });
  if (out_bytes) std::memcpy(out, b.download.mapped(), out_bytes);
  return b.timestamps.read();
}

GpuTimes texture_backward(Device& device, const raster::TextureParams<float>& p, const float* grad_out,
                          const raster::TextureGrads<float>& grads) {
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

  Device::Impl& dev = device.impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  Buffers& b = buffers_of(dev);
  std::vector<std::int32_t> levels;
  const std::vector<Upload> uploads = sampling_inputs(b, p, levels);
  const std::int64_t S = p.num_samples, C = p.channels, L = levels_read(p);
  const std::int64_t values = texels_read(p) * C, base_values = base_texels(p) * C;
  // The texel gradients downloaded: level 0's, and the user's levels when wanted.
  const std::int64_t converted = !texels ? 0 : want_pyramid ? values : base_values;
  const std::size_t grad_bytes = static_cast<std::size_t>(S * C) * sizeof(float);
  const std::size_t sample_bytes = per_sample ? static_cast<std::size_t>(S * kSampleGrads) * sizeof(float) : 0;
  const std::size_t tex_bytes = static_cast<std::size_t>(converted) * sizeof(float);
  b[kValues].reserve(dev, grad_bytes, false);
  b[kSums].reserve(dev, texels ? static_cast<std::size_t>(values) * sizeof(std::int64_t) : 0, false);
  b[kLargest].reserve(dev, 2 * sizeof(std::uint64_t), false);
  b[kSampleGradOut].reserve(dev, static_cast<std::size_t>(S * kSampleGrads) * sizeof(float), false);
  b[kTexGrad].reserve(dev, tex_bytes, false);
  b.download.reserve(dev, sample_bytes + tex_bytes, true);
  const std::size_t grad_from = stage(b, uploads, grad_bytes);
  if (grad_bytes) std::memcpy(static_cast<char*>(b.upload.mapped()) + grad_from, grad_out, grad_bytes);
  // Bindings: as the forward, 6 grad_out, 7 sums, 8 largest, 9 per-sample gradients;
  // texture_finish: 1 levels, 7 sums, 8 largest, 9 texel gradients.
  const VkDescriptorSet set =
      b.bind(b.sample_set, {{0, kTexels}, {1, kLevels}, {2, kUv}, {3, kUvDx}, {4, kUvDy}, {5, kBias},
                            {6, kValues}, {7, kSums}, {8, kLargest}, {9, kSampleGradOut}});
  const VkDescriptorSet finish_set = b.bind(b.finish_set, {{1, kLevels}, {7, kSums}, {8, kLargest}, {9, kTexGrad}});
  TexturePush push = push_of(p);
  push.flags |= (lod ? kLodGrads : 0) | (texels ? kTexelGrads : 0);
  TextureFinishPush finish{0, static_cast<std::int32_t>(values), static_cast<std::int32_t>(C), 0,
                           push.contributions, 0, {}};
  dev.run([&](VkCommandBuffer cb) {
    b.timestamps.begin(cb, 6);
    record_uploads(cb, b, uploads);
    copy(cb, b.upload.handle(), grad_from, b[kValues].handle(), 0, grad_bytes);
    if (texels) vkCmdFillBuffer(cb, b[kSums].handle(), 0, static_cast<std::size_t>(values) * sizeof(std::int64_t), 0u);
    vkCmdFillBuffer(cb, b[kLargest].handle(), 0, 2 * sizeof(std::uint64_t), 0u);
    barrier(cb);
    b.timestamps.stamp(cb, 1);
    b.use(cb, set);
    dispatch(cb, b.k, b.k.texture_backward, &push, S, 256);  // pass 0
    barrier(cb);
    b.timestamps.stamp(cb, 2);
    if (texels) {
      push.pass = 1;
      dispatch(cb, b.k, b.k.texture_backward, &push, S, 256);
      barrier(cb);
    }
    b.timestamps.stamp(cb, 3);
    if (texels) {
      b.use(cb, finish_set);
      if (p.user_pyramid || L == 1) {  // every level keeps its own gradient
        finish.mode = 2;
        finish.count = static_cast<std::int32_t>(converted);
        dispatch(cb, b.k, b.k.texture_finish, &finish, converted, 256);
      } else {  // the coarsest level to double, then down the pyramid to level 0's floats
        const raster::MipLevel& top = p.layout.levels[L - 1];
        finish.first = static_cast<std::int32_t>(top.offset * C);
        dispatch(cb, b.k, b.k.texture_finish, &finish, values - finish.first, 256);
        barrier(cb);
        finish.mode = 1;
        for (std::int32_t l = static_cast<std::int32_t>(L) - 1; l >= 1; --l) {
          finish.level = l;
          dispatch(cb, b.k, b.k.texture_finish, &finish,
                   std::int64_t(p.layout.levels[l].height) * p.layout.levels[l].width, 256);
          barrier(cb);
        }
      }
      barrier(cb);
    }
    b.timestamps.stamp(cb, 4);
    copy(cb, b[kSampleGradOut].handle(), 0, b.download.handle(), 0, sample_bytes);
    copy(cb, b[kTexGrad].handle(), 0, b.download.handle(), sample_bytes, tex_bytes);
    barrier(cb);
    b.timestamps.stamp(cb, 5);
  });
  const float* got = static_cast<const float*>(b.download.mapped());
  for (std::int64_t s = 0; per_sample && s < S; ++s) {
    const float* g = got + kSampleGrads * s;
    if (want_uv) add_to(want_uv + 2 * s, g, 2);
    if (want_dx) add_to(want_dx + 2 * s, g + 2, 2);
    if (want_dy) add_to(want_dy + 2 * s, g + 4, 2);
    if (want_bias) want_bias[s] += g[6];
  }
  const float* tex_grad = got + sample_bytes / sizeof(float);
  if (texels) {
    add_to(grads.tex, tex_grad, base_values);
    add_to(want_pyramid, tex_grad + base_values, converted - base_values);
  }
  return b.timestamps.read();
}

}  // namespace gr::vulkan
