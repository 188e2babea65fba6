// Buffers with their own memory (see internal/buffer.h).
#include "raster/vulkan/internal/buffer.h"

#include "autodiff/base/error.h"

namespace gr::vulkan {

void Buffer::reset() {
  if (!dev_) return;
  if (buffer_) vkDestroyBuffer(dev_->device, buffer_, nullptr);
  if (memory_) vkFreeMemory(dev_->device, memory_, nullptr);
  buffer_ = VK_NULL_HANDLE;
  memory_ = VK_NULL_HANDLE;
  mapped_ = nullptr;
  size_ = 0;
}

void Buffer::reserve(Device::Impl& dev, std::size_t bytes, bool host) {
  if (bytes == 0) bytes = 16;
  if (buffer_ && size_ >= bytes) return;
  reset();
  dev_ = &dev;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = bytes;
  bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(dev.device, &bci, nullptr, &buffer_), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(dev.device, buffer_, &req);
  const VkMemoryPropertyFlags want =
      host ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT
           : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  int type = dev.memory_type(req.memoryTypeBits, want);
  if (type < 0 && host)
    type = dev.memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  if (type < 0) type = dev.memory_type(req.memoryTypeBits, 0);
  if (type < 0) {
    reset();
    throw Error("vulkan: no memory type for a buffer");
  }
  VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = static_cast<std::uint32_t>(type);
  const VkResult r = vkAllocateMemory(dev.device, &ai, nullptr, &memory_);
  if (r != VK_SUCCESS) {
    reset();
    throw MemoryError("vulkan: could not allocate " + std::to_string(bytes) + " bytes of " +
                      (host ? "host-visible" : "device") + " memory (VkResult " + std::to_string(r) + ")");
  }
  check(vkBindBufferMemory(dev.device, buffer_, memory_, 0), "vkBindBufferMemory");
  if (host) check(vkMapMemory(dev.device, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory");
  size_ = bytes;
}

}  // namespace gr::vulkan
