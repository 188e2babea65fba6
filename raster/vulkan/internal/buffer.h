// Internal to the Vulkan path: a buffer with its memory, and a reusable set of
// them that grows to the largest size asked (so repeated calls allocate once).
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>

#include "raster/vulkan/internal/context.h"

namespace gr::vulkan {

class Buffer {
 public:
  Buffer() = default;
  ~Buffer() { reset(); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  // Makes the buffer at least `bytes` long (contents undefined after growing).
  // host: host-visible and coherent (staging); else device-local.
  void reserve(Device::Impl& dev, std::size_t bytes, bool host);
  void reset();

  VkBuffer handle() const { return buffer_; }
  std::size_t size() const { return size_; }
  void* mapped() const { return mapped_; }  // host buffers only

 private:
  Device::Impl* dev_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  std::size_t size_ = 0;
  void* mapped_ = nullptr;
};

}  // namespace gr::vulkan
