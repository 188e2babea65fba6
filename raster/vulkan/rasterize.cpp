// The GPU rasterizer's passes (docs/gpu.md):
//   project      per vertex: screen position, z_ndc, flags (as the CPU's projection)
//   raster_small per triangle (pass 0): classify; scan small boxes into the
//                depth keys (atomic min); list the large ones
//   raster_large per listed triangle, a workgroup over its box (pass 0)
//   raster_small, raster_large again (pass 1): the smallest id at the winning depth
//   resolve      per pixel: the winner's (u, v, depth), or the background
#include "raster/vulkan/rasterize.h"

#include <cstring>
#include <map>
#include <memory>
#include <string>

#include "autodiff/error.h"
#include "raster/vulkan/internal/buffer.h"
#include "raster/vulkan/internal/pipeline.h"
#include "raster/vulkan/internal/shaders.h"

namespace gr::vulkan {
namespace {

// Workgroups of raster_large; each takes listed triangles in turn.
constexpr std::uint32_t kLargeWorkgroups = 1024;
constexpr std::uint32_t kMaxGroupsX = 65535;

// Timestamps: start, uploaded, cleared, projected, depth pass, id pass, resolved, downloaded.
constexpr std::uint32_t kTimestamps = 8;

struct PushConstants {
  std::int32_t width, height, num_vertices, num_tris, cull, pass, y_up, pad;
};
static_assert(sizeof(PushConstants) == kPushBytes, "push constant block");

enum Binding : std::uint32_t { kClip, kTris, kVerts, kKeys, kIds, kLarge, kTriIdOut, kUvOut, kDepthOut };

struct RasterState {
  explicit RasterState(Device::Impl& dev) : pipelines(dev) {
    const shaders::Spirv pr = shaders::project(), sm = shaders::raster_small(), lg = shaders::raster_large(),
                         rs = shaders::resolve();
    project = pipelines.add(pr.words, pr.count);
    small_words = sm;
    large = pipelines.add(lg.words, lg.count);
    resolve = pipelines.add(rs.words, rs.count);
    VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = kTimestamps;
    check(vkCreateQueryPool(dev.device, &qi, nullptr, &queries), "vkCreateQueryPool");
    device = dev.device;
  }
  ~RasterState() {
    if (queries) vkDestroyQueryPool(device, queries, nullptr);
  }

  PipelineSet pipelines;
  VkPipeline project, large, resolve;
  // raster_small by its small_box specialization.
  shaders::Spirv small_words;
  std::map<int, VkPipeline> small;
  VkQueryPool queries = VK_NULL_HANDLE;
  VkDevice device;
  Buffer buffers[kBindings];
  Buffer upload, download;
};

VkPipeline small_pipeline(RasterState& st, int small_box) {
  auto it = st.small.find(small_box);
  if (it != st.small.end()) return it->second;
  return st.small[small_box] = st.pipelines.add(st.small_words.words, st.small_words.count, {small_box});
}

RasterState& state_of(Device::Impl& dev) {
  if (!dev.raster_state) dev.raster_state = std::make_shared<RasterState>(dev);
  return *static_cast<RasterState*>(dev.raster_state.get());
}

// Makes the compute writes so far visible to what follows (compute or copies).
void barrier(VkCommandBuffer cb) {
  VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT;
  vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &mb, 0,
                       nullptr, 0, nullptr);
}

// One invocation per item, `local` per workgroup, in rows of at most 65535 workgroups.
void dispatch_items(VkCommandBuffer cb, std::int64_t items, std::uint32_t local) {
  const std::int64_t groups = (items + local - 1) / local;
  if (groups == 0) return;
  const std::uint32_t x = static_cast<std::uint32_t>(groups < kMaxGroupsX ? groups : kMaxGroupsX);
  const std::uint32_t y = static_cast<std::uint32_t>((groups + x - 1) / x);
  vkCmdDispatch(cb, x, y, 1);
}

}  // namespace

void rasterize_forward(Device& device, const raster::RasterParams<float>& p, std::int32_t* tri_id, float* uv,
                       float* depth, const GpuRasterOptions& options, GpuTimes* times) {
  if (p.floor_id || p.floor_z)
    throw ValueError("vulkan rasterize: depth peeling (floor_id, floor_z) is not on the GPU yet");
  if (options.small_box < 1)
    throw ValueError("vulkan rasterize: small_box must be at least 1, got " + std::to_string(options.small_box));
  Device::Impl& dev = device.impl();
  std::lock_guard<std::mutex> lock(dev.mutex);
  RasterState& st = state_of(dev);

  const int W = p.settings.width, H = p.settings.height;
  const std::int64_t pixels = static_cast<std::int64_t>(W) * H;
  const std::size_t clip_bytes = static_cast<std::size_t>(p.num_vertices) * 4 * sizeof(float);
  const std::size_t tri_bytes = static_cast<std::size_t>(p.num_tris) * 3 * sizeof(std::int32_t);
  const std::size_t px = static_cast<std::size_t>(pixels);
  const std::size_t out_bytes[3] = {px * sizeof(std::int32_t), px * 2 * sizeof(float), px * sizeof(float)};

  Buffer* b = st.buffers;
  b[kClip].reserve(dev, clip_bytes, false);
  b[kTris].reserve(dev, tri_bytes, false);
  b[kVerts].reserve(dev, static_cast<std::size_t>(p.num_vertices) * 32, false);
  b[kKeys].reserve(dev, px * sizeof(std::uint64_t), false);
  b[kIds].reserve(dev, px * sizeof(std::int32_t), false);
  b[kLarge].reserve(dev, (static_cast<std::size_t>(p.num_tris) + 1) * sizeof(std::uint32_t), false);
  b[kTriIdOut].reserve(dev, out_bytes[0], false);
  b[kUvOut].reserve(dev, out_bytes[1], false);
  b[kDepthOut].reserve(dev, out_bytes[2], false);
  st.upload.reserve(dev, clip_bytes + tri_bytes, true);
  st.download.reserve(dev, out_bytes[0] + out_bytes[1] + out_bytes[2], true);
  if (clip_bytes) std::memcpy(st.upload.mapped(), p.clip, clip_bytes);
  if (tri_bytes) std::memcpy(static_cast<char*>(st.upload.mapped()) + clip_bytes, p.tris, tri_bytes);

  VkBuffer handles[kBindings];
  for (std::uint32_t i = 0; i < kBindings; ++i) handles[i] = b[i].handle();
  const VkDescriptorSet set = st.pipelines.bind(handles);
  const bool timed = dev.info.timestamp_period_ns > 0.0;
  PushConstants pc{W, H, static_cast<std::int32_t>(p.num_vertices), static_cast<std::int32_t>(p.num_tris),
                   p.settings.cull == raster::Cull::Back ? 1 : p.settings.cull == raster::Cull::Front ? -1 : 0,
                   0, options.y_up ? 1 : 0, 0};

  const VkPipeline small = small_pipeline(st, options.small_box);
  dev.run([&](VkCommandBuffer cb) {
    auto stamp = [&](VkPipelineStageFlagBits stage, std::uint32_t i) {
      if (timed) vkCmdWriteTimestamp(cb, stage, st.queries, i);
    };
    if (timed) {
      vkCmdResetQueryPool(cb, st.queries, 0, kTimestamps);
      vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, st.queries, 0);
    }
    if (clip_bytes) {
      const VkBufferCopy c{0, 0, clip_bytes};
      vkCmdCopyBuffer(cb, st.upload.handle(), b[kClip].handle(), 1, &c);
    }
    if (tri_bytes) {
      const VkBufferCopy c{clip_bytes, 0, tri_bytes};
      vkCmdCopyBuffer(cb, st.upload.handle(), b[kTris].handle(), 1, &c);
    }
    stamp(VK_PIPELINE_STAGE_TRANSFER_BIT, 1);
    // Keys "beyond everything", ids "none", an empty large list.
    vkCmdFillBuffer(cb, b[kKeys].handle(), 0, px * sizeof(std::uint64_t), 0xffffffffu);
    vkCmdFillBuffer(cb, b[kIds].handle(), 0, px * sizeof(std::int32_t), 0x7fffffffu);
    vkCmdFillBuffer(cb, b[kLarge].handle(), 0, sizeof(std::uint32_t), 0u);
    barrier(cb);
    stamp(VK_PIPELINE_STAGE_TRANSFER_BIT, 2);

    const VkPipelineLayout layout = st.pipelines.layout();
    vkCmdBindDescriptorSets(cb, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, nullptr);
    auto push = [&](std::int32_t pass) {
      pc.pass = pass;
      vkCmdPushConstants(cb, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, kPushBytes, &pc);
    };
    push(0);
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, st.project);
    dispatch_items(cb, p.num_vertices, 256);
    barrier(cb);
    stamp(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 3);
    for (std::int32_t pass = 0; pass < 2; ++pass) {
      push(pass);
      vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, small);
      dispatch_items(cb, p.num_tris, 64);
      barrier(cb);
      vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, st.large);
      if (p.num_tris > 0) vkCmdDispatch(cb, kLargeWorkgroups, 1, 1);
      barrier(cb);
      stamp(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 4 + pass);
    }
    vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, st.resolve);
    dispatch_items(cb, pixels, 256);
    barrier(cb);
    stamp(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 6);

    std::size_t offset = 0;
    const Binding outs[3] = {kTriIdOut, kUvOut, kDepthOut};
    for (int k = 0; k < 3; ++k) {
      const VkBufferCopy c{0, offset, out_bytes[k]};
      vkCmdCopyBuffer(cb, b[outs[k]].handle(), st.download.handle(), 1, &c);
      offset += out_bytes[k];
    }
    stamp(VK_PIPELINE_STAGE_TRANSFER_BIT, 7);
  });

  const char* out = static_cast<const char*>(st.download.mapped());
  std::memcpy(tri_id, out, out_bytes[0]);
  std::memcpy(uv, out + out_bytes[0], out_bytes[1]);
  std::memcpy(depth, out + out_bytes[0] + out_bytes[1], out_bytes[2]);

  if (times) {
    *times = GpuTimes{};
    std::uint64_t ts[kTimestamps];
    if (timed && vkGetQueryPoolResults(dev.device, st.queries, 0, kTimestamps, sizeof(ts), ts, sizeof(std::uint64_t),
                                       VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT) == VK_SUCCESS) {
      const double ms = dev.info.timestamp_period_ns * 1e-6;
      auto span = [&](int a, int b) { return static_cast<double>(ts[b] - ts[a]) * ms; };
      times->upload_ms = span(0, 1);
      times->kernels_ms = span(1, 6);
      times->download_ms = span(6, 7);
      for (int i = 1; i < 6; ++i) times->pass_ms.push_back(span(i, i + 1));
    }
  }
}

}  // namespace gr::vulkan
