// Internal to the Vulkan path: compute pipelines that share one layout of
// storage buffers (bindings 0..kBindings-1) and a 32-byte push-constant block,
// and the descriptor sets that bind buffers to them.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <vector>

#include "raster/vulkan/internal/context.h"

namespace gr::vulkan {

constexpr std::uint32_t kBindings = 10;
constexpr std::uint32_t kPushBytes = 32;

class PipelineSet {
 public:
  explicit PipelineSet(Device::Impl& dev);
  ~PipelineSet();
  PipelineSet(const PipelineSet&) = delete;
  PipelineSet& operator=(const PipelineSet&) = delete;

  // A pipeline for one SPIR-V module (entry point "main"); spec: values of
  // the int specialization constants 0, 1, ...
  VkPipeline add(const std::uint32_t* words, std::size_t count, const std::vector<std::int32_t>& spec = {});
  VkPipelineLayout layout() const { return layout_; }
  VkDescriptorSetLayout set_layout() const { return set_layout_; }

 private:
  Device::Impl& dev_;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  std::vector<VkShaderModule> modules_;
  std::vector<VkPipeline> pipelines_;
};

// One descriptor set of a PipelineSet's layout, with its own pool.
class DescriptorSet {
 public:
  DescriptorSet(Device::Impl& dev, const PipelineSet& pipelines);
  ~DescriptorSet();
  DescriptorSet(const DescriptorSet&) = delete;
  DescriptorSet& operator=(const DescriptorSet&) = delete;

  // The set, now with buffers[i] at binding i (VK_NULL_HANDLE: unused). Not
  // while a command that uses it runs.
  VkDescriptorSet bind(const VkBuffer (&buffers)[kBindings]);

 private:
  Device::Impl& dev_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkDescriptorSet set_ = VK_NULL_HANDLE;
};

}  // namespace gr::vulkan
