// The texture lookups' command buffers (internal/texture_call.h): each call
// uploads the texels (every level it reads, face by face; unless the device
// keeps them: the texel cache below), the samples' inputs, runs the passes
// and downloads what was asked, in one command buffer with timestamps between.
#include "raster/vulkan/internal/texture_call.h"

#include <atomic>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <utility>

#include "raster/vulkan/internal/buffer.h"

namespace gr::vulkan {
namespace {

// texture_finish.comp's push constants.
struct TextureFinishPush {
  std::int32_t mode, count, channels, level, contributions, first, faces, face_texels;
};
// texture_mip.comp's push constants.
struct TextureMipPush {
  std::int32_t level, channels, count, faces, face_values, unused[3];
};
static_assert(sizeof(TexturePush) == kPushBytes && sizeof(TextureFinishPush) == kPushBytes &&
                  sizeof(TextureMipPush) == kPushBytes,
              "push constant blocks");

// Kept texels' serials, unique in the process: a serial from another device
// (or one gone) never matches.
std::atomic<std::uint64_t> g_texel_serial{0};

// One call's texels kept on the device, and what they are (a call reading
// other levels or sizes does not match).
struct KeptCopy {
  std::uint64_t serial = 0;
  std::unique_ptr<Buffer> buffer;
  std::size_t bytes = 0;
  std::vector<std::int32_t> levels;
  bool cube = false;
  std::uint64_t used = 0;  // the clock at its last use
};

enum Role { kTexels, kLevels, kUv, kUvDx, kUvDy, kBias, kValues, kSums, kLargest, kSampleGradOut, kTexGrad, kRoles };

// The device's texture buffers (Device::Impl::texture_buffers), grown to the
// largest call and reused.
struct Buffers {
  Buffers(Device::Impl& dev, Kernels& k)
      : dev(dev),
        k(k),
        sample_set(dev, k.pipelines),
        finish_set(dev, k.pipelines),
        mip_set(dev, k.pipelines),
        timestamps(dev, 6) {}
  Device::Impl& dev;
  Kernels& k;
  Buffer buffers[kRoles];
  Buffer upload, download;
  DescriptorSet sample_set, finish_set, mip_set;
  Timestamps timestamps;
  // The texel cache (texture.h's KeptTexels): at most kKeptTextures copies,
  // kKeptTextureBytes in all; and this call's texels (a copy's or kTexels).
  std::vector<KeptCopy> kept;
  std::uint64_t clock = 0;
  TextureResidency stats;
  VkBuffer texels = VK_NULL_HANDLE;

  Buffer& operator[](Role r) { return buffers[r]; }
  VkDescriptorSet bind(DescriptorSet& set, std::initializer_list<std::pair<std::uint32_t, Role>> bindings) {
    VkBuffer handles[kBindings] = {};
    for (const auto& [binding, role] : bindings) handles[binding] = role == kTexels ? texels : buffers[role].handle();
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

// Host arrays to device buffers through the upload staging buffer.
struct Upload {
  Role role;
  const void* data;
  std::size_t bytes;
};

std::size_t texel_bytes(const TextureCall& call) {
  std::size_t bytes = 0;
  for (const TextureCall::Upload& t : call.texels) bytes += t.bytes;
  return bytes;
}
// The bytes of every level read, every face (what the shaders read).
std::size_t all_texel_bytes(const TextureCall& call) {
  return static_cast<std::size_t>(call.faces() * call.face_texels * call.push.channels) * sizeof(float);
}

// Where the call's texels are (sets b.texels): the kept copy kept->serial
// names when the device still keeps it for these levels (returns false: no
// upload), else a new kept copy (with kept; the least recently used let go
// while over the bounds) or the kTexels buffer, to upload into (true).
bool place_texels(Buffers& b, const TextureCall& call, KeptTexels* kept) {
  const std::size_t bytes = all_texel_bytes(call);
  auto same = [&](const KeptCopy& c) {
    return c.serial == kept->serial && c.bytes == bytes && c.cube == call.cube && c.levels == call.levels;
  };
  if (kept && kept->serial)
    for (KeptCopy& c : b.kept)
      if (same(c)) {
        c.used = ++b.clock;
        b.texels = c.buffer->handle();
        ++b.stats.resident_calls;
        return false;
      }
  ++b.stats.uploads;
  b.stats.upload_bytes += static_cast<std::int64_t>(texel_bytes(call));
  if (!kept || bytes == 0 || bytes > kKeptTextureBytes) {
    if (kept) kept->serial = 0;
    b[kTexels].reserve(b.dev, bytes, false);
    b.texels = b[kTexels].handle();
    return true;
  }
  auto total = [&] {
    std::size_t sum = 0;
    for (const KeptCopy& c : b.kept) sum += c.bytes;
    return sum;
  };
  while (!b.kept.empty() && (b.kept.size() >= static_cast<std::size_t>(kKeptTextures) ||
                             total() + bytes > kKeptTextureBytes)) {
    auto oldest = b.kept.begin();
    for (auto c = b.kept.begin(); c != b.kept.end(); ++c)
      if (c->used < oldest->used) oldest = c;
    b.kept.erase(oldest);
  }
  KeptCopy c;
  c.serial = ++g_texel_serial;
  c.buffer = std::make_unique<Buffer>();
  c.buffer->reserve(b.dev, bytes, false);
  c.bytes = bytes;
  c.levels = call.levels;
  c.cube = call.cube;
  c.used = ++b.clock;
  b.texels = c.buffer->handle();
  kept->serial = c.serial;
  b.kept.push_back(std::move(c));
  return true;
}

// Reserves the sampling inputs' buffers for `call`: texels (one after the
// other, unless kept on the device), levels, uv, uv_dx, uv_dy, bias.
std::vector<Upload> sampling_inputs(Buffers& b, const TextureCall& call, KeptTexels* kept) {
  std::vector<Upload> up;
  if (place_texels(b, call, kept))
    for (const TextureCall::Upload& t : call.texels) up.push_back({kTexels, t.data, t.bytes});
  up.push_back({kLevels, call.levels.data(), call.levels.size() * sizeof(std::int32_t)});
  up.push_back({kUv, call.uv.data, call.uv.bytes});
  up.push_back({kUvDx, call.uv_dx.data, call.uv_dx.bytes});
  up.push_back({kUvDy, call.uv_dy.data, call.uv_dy.bytes});
  up.push_back({kBias, call.bias.data, call.bias.bytes});
  for (const Upload& u : up)
    if (u.role != kTexels) b[u.role].reserve(b.dev, u.bytes, false);
  return up;
}

bool uploads_texels(const std::vector<Upload>& uploads) {
  for (const Upload& u : uploads)
    if (u.role == kTexels) return true;
  return false;
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

// Records the passes that make levels 1.. from level 0 in the texels
// (call.build_levels; after the uploads, each level after its parent, every
// face's at once).
void record_mip_build(VkCommandBuffer cb, Buffers& b, const TextureCall& call, VkDescriptorSet set) {
  b.use(cb, set);
  const auto face_values = static_cast<std::int32_t>(call.face_texels * call.push.channels);
  for (std::int32_t l = 1; l < call.push.levels; ++l) {
    const std::int32_t count = call.levels[4 * l] * call.levels[4 * l + 1];
    const TextureMipPush push{l, call.push.channels, count, call.faces(), face_values, {}};
    dispatch(cb, b.k, b.k.texture_mip, &push, std::int64_t(count) * call.faces(), 256);
    barrier(cb);
  }
}

// Records the staged uploads: the texels' parts one after the other, or
// with call.build_levels each face's level 0 at its face's start (its levels
// 1.. made there after).
void record_uploads(VkCommandBuffer cb, Buffers& b, const TextureCall& call, const std::vector<Upload>& uploads) {
  const std::size_t face_bytes = static_cast<std::size_t>(call.face_texels * call.push.channels) * sizeof(float);
  std::size_t from = 0, texel_offset = 0;
  for (const Upload& u : uploads) {
    const std::size_t to = u.role == kTexels ? texel_offset : 0;
    copy(cb, b.upload.handle(), from, u.role == kTexels ? b.texels : b[u.role].handle(), to, u.bytes);
    if (u.role == kTexels) texel_offset += call.build_levels ? face_bytes : u.bytes;
    from += u.bytes;
  }
}

}  // namespace

TextureResidency texture_residency(Device& device) {
  Device::Impl& dev = device.impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  Buffers& b = buffers_of(dev);
  TextureResidency r = b.stats;
  r.kept = static_cast<int>(b.kept.size());
  r.kept_bytes = 0;
  for (const KeptCopy& c : b.kept) r.kept_bytes += c.bytes;
  return r;
}

GpuTimes run_texture_forward(Device& device, const TextureCall& call, float* out, KeptTexels* kept) {
  Device::Impl& dev = device.impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  Buffers& b = buffers_of(dev);
  const std::vector<Upload> uploads = sampling_inputs(b, call, kept);
  const std::size_t out_bytes = static_cast<std::size_t>(call.push.num_samples) * call.push.channels * sizeof(float);
  b[kValues].reserve(dev, out_bytes, false);
  b.download.reserve(dev, out_bytes, true);
  stage(b, uploads, 0);
  // Bindings (texture_common.glsl): 0 texels, 1 levels, 2 uv, 3 uv_dx, 4 uv_dy, 5 bias, 6 out.
  const VkDescriptorSet set = b.bind(b.sample_set, {{0, kTexels}, {1, kLevels}, {2, kUv}, {3, kUvDx}, {4, kUvDy},
                                                    {5, kBias}, {6, kValues}});
  const VkPipeline pipeline = call.cube ? b.k.cube_texture_forward : b.k.texture_forward;
  const bool build = call.build_levels && uploads_texels(uploads);
  const VkDescriptorSet mip_set = build ? b.bind(b.mip_set, {{0, kTexels}, {1, kLevels}}) : VK_NULL_HANDLE;
  dev.run([&](VkCommandBuffer cb) {
    b.timestamps.begin(cb, 4);
    record_uploads(cb, b, call, uploads);
    barrier(cb);
    if (build) record_mip_build(cb, b, call, mip_set);
    b.timestamps.stamp(cb, 1);
    b.use(cb, set);
    dispatch(cb, b.k, pipeline, &call.push, call.push.num_samples, 256);
    barrier(cb);
    b.timestamps.stamp(cb, 2);
    copy(cb, b[kValues].handle(), 0, b.download.handle(), 0, out_bytes);
    barrier(cb);
    b.timestamps.stamp(cb, 3);
  });
  if (out_bytes) std::memcpy(out, b.download.mapped(), out_bytes);
  return b.timestamps.read();
}

GpuTimes run_texture_backward(Device& device, const TextureCall& call, const float* grad_out, bool per_sample,
                              bool texels, const std::function<void(const float*, const float*)>& take,
                              KeptTexels* kept) {
  Device::Impl& dev = device.impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  Buffers& b = buffers_of(dev);
  const std::vector<Upload> uploads = sampling_inputs(b, call, kept);
  const std::int64_t S = call.push.num_samples, C = call.push.channels, L = call.push.levels;
  const std::int64_t face_values = call.face_texels * C, values = call.faces() * face_values;
  // The texel gradients downloaded: every face's level 0, or every level kept.
  const std::int64_t converted = !texels ? 0 : call.keep_levels ? values : call.faces() * call.base_texels * C;
  const std::size_t grad_bytes = static_cast<std::size_t>(S * C) * sizeof(float);
  const std::size_t sample_bytes = per_sample ? static_cast<std::size_t>(S * call.sample_grads) * sizeof(float) : 0;
  const std::size_t tex_bytes = static_cast<std::size_t>(converted) * sizeof(float);
  b[kValues].reserve(dev, grad_bytes, false);
  b[kSums].reserve(dev, texels ? static_cast<std::size_t>(values) * sizeof(std::int64_t) : 0, false);
  b[kLargest].reserve(dev, 2 * sizeof(std::uint64_t), false);
  b[kSampleGradOut].reserve(dev, static_cast<std::size_t>(S * call.sample_grads) * sizeof(float), false);
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
  const VkPipeline pipeline = call.cube ? b.k.cube_texture_backward : b.k.texture_backward;
  const bool build = call.build_levels && uploads_texels(uploads);
  const VkDescriptorSet mip_set = build ? b.bind(b.mip_set, {{0, kTexels}, {1, kLevels}}) : VK_NULL_HANDLE;
  TexturePush push = call.push;
  push.flags |= texels ? kTexelGrads : 0;
  TextureFinishPush finish{0, static_cast<std::int32_t>(face_values), static_cast<std::int32_t>(C), 0,
                           push.contributions, 0, call.faces(), static_cast<std::int32_t>(call.face_texels)};
  dev.run([&](VkCommandBuffer cb) {
    b.timestamps.begin(cb, 6);
    record_uploads(cb, b, call, uploads);
    copy(cb, b.upload.handle(), grad_from, b[kValues].handle(), 0, grad_bytes);
    if (texels) vkCmdFillBuffer(cb, b[kSums].handle(), 0, static_cast<std::size_t>(values) * sizeof(std::int64_t), 0u);
    vkCmdFillBuffer(cb, b[kLargest].handle(), 0, 2 * sizeof(std::uint64_t), 0u);
    barrier(cb);
    if (build) record_mip_build(cb, b, call, mip_set);
    b.timestamps.stamp(cb, 1);
    b.use(cb, set);
    dispatch(cb, b.k, pipeline, &push, S, 256);  // pass 0
    barrier(cb);
    b.timestamps.stamp(cb, 2);
    if (texels) {
      push.pass = 1;
      dispatch(cb, b.k, pipeline, &push, S, 256);
      barrier(cb);
    }
    b.timestamps.stamp(cb, 3);
    if (texels) {
      b.use(cb, finish_set);
      if (call.keep_levels || L == 1) {  // every level keeps its own gradient
        finish.mode = 2;
        finish.count = static_cast<std::int32_t>(converted);
        dispatch(cb, b.k, b.k.texture_finish, &finish, converted, 256);
      } else {  // each face's coarsest level to double, then down the pyramid to level 0's floats
        const std::int32_t top = call.levels[4 * (L - 1) + 2];
        finish.first = static_cast<std::int32_t>(top * C);
        dispatch(cb, b.k, b.k.texture_finish, &finish, call.faces() * (face_values - finish.first), 256);
        barrier(cb);
        finish.mode = 1;
        for (std::int32_t l = static_cast<std::int32_t>(L) - 1; l >= 1; --l) {
          finish.level = l;
          dispatch(cb, b.k, b.k.texture_finish, &finish,
                   call.faces() * std::int64_t(call.levels[4 * l]) * call.levels[4 * l + 1], 256);
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
  take(per_sample ? got : nullptr, texels ? got + sample_bytes / sizeof(float) : nullptr);
  return b.timestamps.read();
}

}  // namespace gr::vulkan
