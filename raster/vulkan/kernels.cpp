// The device's compiled kernels and the recording helpers (internal/kernels.h).
#include "raster/vulkan/internal/kernels.h"

#include <limits>
#include <memory>
#include <string>

#include "autodiff/base/error.h"

namespace gr::vulkan {

namespace {
constexpr std::uint32_t kMaxGroupsX = 65535;

VkPipeline add(PipelineSet& set, shaders::Spirv s, const std::vector<std::int32_t>& spec = {}) {
  return set.add(s.words, s.count, spec);
}
}  // namespace

Kernels::Kernels(Device::Impl& dev) : pipelines(dev) {
  project = add(pipelines, shaders::project());
  raster_large = add(pipelines, shaders::raster_large());
  resolve = add(pipelines, shaders::resolve());
  interpolate_forward = add(pipelines, shaders::interpolate_forward());
  interpolate_backward = add(pipelines, shaders::interpolate_backward());
  fixed_point_finish = add(pipelines, shaders::fixed_point_finish());
  gbuffer = add(pipelines, shaders::gbuffer());
  gbuffer_backward = add(pipelines, shaders::gbuffer_backward());
  antialias_pairs = add(pipelines, shaders::antialias_pairs());
  antialias_forward = add(pipelines, shaders::antialias_forward());
  antialias_backward = add(pipelines, shaders::antialias_backward());
  antialias_finish = add(pipelines, shaders::antialias_finish());
  visibility_pairs = add(pipelines, shaders::visibility_pairs());
  texture_forward = add(pipelines, shaders::texture_forward());
  texture_backward = add(pipelines, shaders::texture_backward());
  texture_finish = add(pipelines, shaders::texture_finish());
  texture_mip = add(pipelines, shaders::texture_mip());
  cube_texture_forward = add(pipelines, shaders::cube_texture_forward());
  cube_texture_backward = add(pipelines, shaders::cube_texture_backward());
}

VkPipeline Kernels::raster_small(int small_box) {
  auto it = small_.find(small_box);
  if (it != small_.end()) return it->second;
  return small_[small_box] = add(pipelines, shaders::raster_small(), {small_box});
}

Kernels& kernels_of(Device::Impl& dev) {
  if (!dev.kernels) dev.kernels = std::make_shared<Kernels>(dev);
  return *static_cast<Kernels*>(dev.kernels.get());
}

void barrier(VkCommandBuffer cb) {
  VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                     VK_ACCESS_TRANSFER_WRITE_BIT;
  vkCmdPipelineBarrier(cb, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &mb, 0,
                       nullptr, 0, nullptr);
}

void dispatch(VkCommandBuffer cb, const Kernels& k, VkPipeline pipeline, const void* push, std::int64_t items,
              std::uint32_t local) {
  if (items > std::numeric_limits<std::int32_t>::max())
    throw Error("vulkan: " + std::to_string(items) + " items in one dispatch; the shaders index with 32-bit ints");
  const std::int64_t groups = (items + local - 1) / local;
  if (groups <= 0) return;
  vkCmdBindPipeline(cb, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdPushConstants(cb, k.pipelines.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, kPushBytes, push);
  const std::uint32_t x = static_cast<std::uint32_t>(groups < kMaxGroupsX ? groups : kMaxGroupsX);
  const std::uint32_t y = static_cast<std::uint32_t>((groups + x - 1) / x);
  vkCmdDispatch(cb, x, y, 1);
}

Timestamps::Timestamps(Device::Impl& dev, std::uint32_t capacity) : dev_(dev), capacity_(capacity) {
  if (dev.info.timestamp_period_ns <= 0.0) return;
  VkQueryPoolCreateInfo qi{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qi.queryCount = capacity;
  check(vkCreateQueryPool(dev.device, &qi, nullptr, &pool_), "vkCreateQueryPool");
}

Timestamps::~Timestamps() {
  if (pool_) vkDestroyQueryPool(dev_.device, pool_, nullptr);
}

void Timestamps::begin(VkCommandBuffer cb, std::uint32_t count) {
  if (count > capacity_) throw Error("vulkan: " + std::to_string(count) + " timestamps asked of a pool of " +
                                     std::to_string(capacity_));
  count_ = count;
  if (pool_) vkCmdResetQueryPool(cb, pool_, 0, capacity_);
  stamp(cb, 0);
}

void Timestamps::stamp(VkCommandBuffer cb, std::uint32_t i) {
  if (pool_ && i < count_) vkCmdWriteTimestamp(cb, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, pool_, i);
}

GpuTimes Timestamps::read() const {
  GpuTimes t;
  std::vector<std::uint64_t> ts(count_);
  if (!pool_ || count_ < 3 || vkGetQueryPoolResults(dev_.device, pool_, 0, count_, ts.size() * sizeof(std::uint64_t), ts.data(),
                                      sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT) !=
                    VK_SUCCESS)
    return t;
  const double ms = dev_.info.timestamp_period_ns * 1e-6;
  auto span = [&](std::uint32_t a, std::uint32_t b) { return static_cast<double>(ts[b] - ts[a]) * ms; };
  const std::uint32_t last = count_ - 1;
  t.upload_ms = span(0, 1);
  t.kernels_ms = span(1, last - 1);
  t.download_ms = span(last - 1, last);
  for (std::uint32_t i = 1; i + 1 < last; ++i) t.pass_ms.push_back(span(i, i + 1));
  return t;
}

void copy(VkCommandBuffer cb, VkBuffer from, std::size_t from_offset, VkBuffer to, std::size_t to_offset,
          std::size_t bytes) {
  if (bytes == 0) return;
  const VkBufferCopy c{from_offset, to_offset, bytes};
  vkCmdCopyBuffer(cb, from, to, 1, &c);
}

}  // namespace gr::vulkan
