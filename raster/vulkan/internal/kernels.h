// Internal to the Vulkan path: the compiled kernels of one device (made once,
// on first use, and kept in Device::Impl), and the helpers that record them.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <map>
#include <vector>

#include "raster/vulkan/internal/pipeline.h"
#include "raster/vulkan/internal/shaders.h"

namespace gr::vulkan {

struct Kernels {
  explicit Kernels(Device::Impl& dev);
  // raster_small for one small_box (a specialization constant), made on first use.
  VkPipeline raster_small(int small_box);

  PipelineSet pipelines;
  VkPipeline project, raster_large, resolve;
  VkPipeline interpolate_forward, interpolate_backward, fixed_point_finish;
  VkPipeline gbuffer, gbuffer_backward;
  VkPipeline antialias_pairs, antialias_forward, antialias_backward, antialias_finish, visibility_pairs;
  VkPipeline texture_forward, texture_backward, texture_finish, texture_mip;
  VkPipeline cube_texture_forward, cube_texture_backward;

 private:
  std::map<int, VkPipeline> small_;
};

// The device's kernels (made on first use). Call with the device's mutex held.
Kernels& kernels_of(Device::Impl& dev);

// Makes the compute and transfer writes so far visible to what follows.
void barrier(VkCommandBuffer cb);

// Binds `pipeline`, pushes `push` (kPushBytes) and dispatches one invocation
// per item (at most 2^31 - 1), `local` per workgroup (the shader's
// WORKGROUP_SIZE), in rows of at most 65535 workgroups: the scheme of
// shaders/dispatch.glsl, whose linear_id() gives each invocation its item.
void dispatch(VkCommandBuffer cb, const Kernels& k, VkPipeline pipeline, const void* push, std::int64_t items,
              std::uint32_t local);

// Timestamps of one submission: begin(cb, n) resets the pool and writes
// stamp 0; the call then writes every one of 1..n-1 (reading a stamp never
// written waits forever), stamp(i) after the work recorded so far; read() converts them into GpuTimes (upload =
// 0..1, kernels = 1..n-2 with a pass per step, download = n-2..n-1).
class Timestamps {
 public:
  Timestamps(Device::Impl& dev, std::uint32_t capacity);
  ~Timestamps();
  Timestamps(const Timestamps&) = delete;
  Timestamps& operator=(const Timestamps&) = delete;

  void begin(VkCommandBuffer cb, std::uint32_t count);
  void stamp(VkCommandBuffer cb, std::uint32_t i);
  GpuTimes read() const;

 private:
  Device::Impl& dev_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  std::uint32_t capacity_, count_ = 0;
};

// Records a copy of `bytes` (if any) between two buffers.
void copy(VkCommandBuffer cb, VkBuffer from, std::size_t from_offset, VkBuffer to, std::size_t to_offset,
          std::size_t bytes);

}  // namespace gr::vulkan
