// Internal to the Vulkan path: the device's handles (Device::Impl) and the
// one-call-at-a-time submission helper. Not installed.
#pragma once

#include <vulkan/vulkan.h>

#include <memory>
#include <mutex>
#include <string>

#include "raster/vulkan/device.h"

namespace gr::vulkan {

// Throws gr::Error("vulkan: <what> failed: <result>") unless r is VK_SUCCESS.
void check(VkResult r, const char* what);

struct Device::Impl {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t queue_family = 0;
  VkCommandPool command_pool = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory{};
  DeviceInfo info;
  std::mutex mutex;  // one call on the queue at a time
  // The compiled kernels (internal/kernels.h) and the Frame that
  // rasterize_forward reuses, made on first use; released before the device.
  std::shared_ptr<void> kernels;
  std::shared_ptr<void> default_frame;
  std::shared_ptr<void> texture_buffers;  // raster/vulkan/texture.cpp's

  ~Impl();

  // Index of a memory type allowed by type_bits with all of `flags`; -1 if none.
  int memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags flags) const;
  // Records with `record`, submits, and waits for the device to finish.
  template <class Record>
  void run(Record&& record);

 private:
  VkCommandBuffer begin();
  void submit_and_wait(VkCommandBuffer cb);
};

template <class Record>
void Device::Impl::run(Record&& record) {
  VkCommandBuffer cb = begin();
  try {
    record(cb);
  } catch (...) {
    vkFreeCommandBuffers(device, command_pool, 1, &cb);
    throw;
  }
  submit_and_wait(cb);
}

}  // namespace gr::vulkan
