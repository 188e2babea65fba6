// Compute pipelines over one shared layout (see internal/pipeline.h).
#include "raster/vulkan/internal/pipeline.h"

namespace gr::vulkan {

PipelineSet::PipelineSet(Device::Impl& dev) : dev_(dev) {
  VkDescriptorSetLayoutBinding b[kBindings];
  for (std::uint32_t i = 0; i < kBindings; ++i)
    b[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo li{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  li.bindingCount = kBindings;
  li.pBindings = b;
  check(vkCreateDescriptorSetLayout(dev.device, &li, nullptr, &set_layout_), "vkCreateDescriptorSetLayout");
  const VkPushConstantRange push{VK_SHADER_STAGE_COMPUTE_BIT, 0, kPushBytes};
  VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pli.setLayoutCount = 1;
  pli.pSetLayouts = &set_layout_;
  pli.pushConstantRangeCount = 1;
  pli.pPushConstantRanges = &push;
  check(vkCreatePipelineLayout(dev.device, &pli, nullptr, &layout_), "vkCreatePipelineLayout");
}

PipelineSet::~PipelineSet() {
  VkDevice d = dev_.device;
  for (VkPipeline p : pipelines_) vkDestroyPipeline(d, p, nullptr);
  for (VkShaderModule m : modules_) vkDestroyShaderModule(d, m, nullptr);
  if (layout_) vkDestroyPipelineLayout(d, layout_, nullptr);
  if (set_layout_) vkDestroyDescriptorSetLayout(d, set_layout_, nullptr);
}

VkPipeline PipelineSet::add(const std::uint32_t* words, std::size_t count, const std::vector<std::int32_t>& spec) {
  VkShaderModuleCreateInfo mi{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  mi.codeSize = count * sizeof(std::uint32_t);
  mi.pCode = words;
  VkShaderModule module;
  check(vkCreateShaderModule(dev_.device, &mi, nullptr, &module), "vkCreateShaderModule");
  modules_.push_back(module);
  std::vector<VkSpecializationMapEntry> entries;
  for (std::uint32_t i = 0; i < spec.size(); ++i)
    entries.push_back({i, static_cast<std::uint32_t>(i * sizeof(std::int32_t)), sizeof(std::int32_t)});
  VkSpecializationInfo si{static_cast<std::uint32_t>(entries.size()), entries.data(),
                          spec.size() * sizeof(std::int32_t), spec.data()};
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = module;
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = spec.empty() ? nullptr : &si;
  ci.layout = layout_;
  VkPipeline pipeline;
  check(vkCreateComputePipelines(dev_.device, VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline), "vkCreateComputePipelines");
  pipelines_.push_back(pipeline);
  return pipeline;
}

DescriptorSet::DescriptorSet(Device::Impl& dev, const PipelineSet& pipelines) : dev_(dev) {
  const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kBindings};
  VkDescriptorPoolCreateInfo dpi{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpi.maxSets = 1;
  dpi.poolSizeCount = 1;
  dpi.pPoolSizes = &size;
  check(vkCreateDescriptorPool(dev.device, &dpi, nullptr, &pool_), "vkCreateDescriptorPool");
  const VkDescriptorSetLayout layout = pipelines.set_layout();
  VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ai.descriptorPool = pool_;
  ai.descriptorSetCount = 1;
  ai.pSetLayouts = &layout;
  const VkResult r = vkAllocateDescriptorSets(dev.device, &ai, &set_);
  if (r != VK_SUCCESS) vkDestroyDescriptorPool(dev.device, pool_, nullptr);
  check(r, "vkAllocateDescriptorSets");
}

DescriptorSet::~DescriptorSet() { vkDestroyDescriptorPool(dev_.device, pool_, nullptr); }

VkDescriptorSet DescriptorSet::bind(const VkBuffer (&buffers)[kBindings]) {
  VkDescriptorBufferInfo info[kBindings];
  VkWriteDescriptorSet w[kBindings];
  std::uint32_t n = 0;
  for (std::uint32_t i = 0; i < kBindings; ++i) {
    if (!buffers[i]) continue;
    info[n] = {buffers[i], 0, VK_WHOLE_SIZE};
    w[n] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w[n].dstSet = set_;
    w[n].dstBinding = i;
    w[n].descriptorCount = 1;
    w[n].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w[n].pBufferInfo = &info[n];
    ++n;
  }
  vkUpdateDescriptorSets(dev_.device, n, w, 0, nullptr);
  return set_;
}

}  // namespace gr::vulkan
