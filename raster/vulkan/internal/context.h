// Internal to the Vulkan path: the device's handles (Device::Impl) and the
// one-call-at-a-time submission helper. Not installed.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

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

  // Deferred calls (raster::DeferredCalls; the caller holds `mutex` for all
  // of these). On a thread between begin_deferring and end_deferring,
  // run(record, finish) submits without waiting and keeps `finish` (what the
  // call does with its results on the host) for complete(); on other threads
  // it waits and runs finish at once. The device runs the deferred
  // submissions while the host records the next. Several threads may defer
  // at once (each on its own frames).
  template <class Record, class Finish>
  std::uint64_t run(Record&& record, Finish&& finish);
  // After the calls before it: at once unless this thread defers, else in
  // call order at complete().
  void then(std::function<void()> finish);
  void begin_deferring();
  // Ends one begin_deferring (the thread defers until every one has ended).
  void end_deferring();
  // Waits for every deferred submission (every thread's), in call order,
  // and runs their finishes; with write_own_outputs false, not those of the
  // calling thread's calls (it is unwinding and their outputs may be gone).
  // Rethrows the first failure after waiting for them all.
  void complete(bool write_own_outputs = true);
  // True while calls up to `ticket` (run's return) may still be pending: a
  // Frame completes them before touching the buffers they use.
  bool pending(std::uint64_t ticket) const { return ticket > completed_; }
  // The submissions this thread has made without waiting since its first
  // begin_deferring (0 when it is not deferring).
  std::int64_t deferred_submissions() const;

 private:
  VkCommandBuffer begin();
  // A command buffer begun and recorded by `record` (freed if it throws).
  template <class Record>
  VkCommandBuffer recorded(Record&& record);
  // Ends cb and submits it with a new fence, which it returns; frees cb and throws on failure.
  VkFence submit(VkCommandBuffer cb);
  void submit_and_wait(VkCommandBuffer cb);
  bool deferring() const;
  // Submits cb with a fence of its own, kept in pending_ with finish.
  void submit_deferred(VkCommandBuffer cb, std::function<void()> finish);

  struct Pending {
    VkCommandBuffer cb = VK_NULL_HANDLE;  // null: a `then` step
    VkFence fence = VK_NULL_HANDLE;
    std::function<void()> finish;
    std::thread::id thread;  // that made the call
  };
  std::vector<Pending> pending_;
  struct Deferring {
    std::thread::id thread;
    int begins;                // not yet ended
    std::int64_t submissions;  // made without waiting
  };
  std::vector<Deferring> deferring_;
  const Deferring* deferring_entry() const;  // this thread's, or null
  Deferring* deferring_entry();
  // Waits for every pending submission and frees it; runs the finishes `run` accepts.
  template <class Run>
  VkResult settle_pending(Run run);
  std::uint64_t issued_ = 0, completed_ = 0;  // tickets of run(record, finish)
};

template <class Record>
VkCommandBuffer Device::Impl::recorded(Record&& record) {
  VkCommandBuffer cb = begin();
  try {
    record(cb);
  } catch (...) {
    vkFreeCommandBuffers(device, command_pool, 1, &cb);
    throw;
  }
  return cb;
}

template <class Record>
void Device::Impl::run(Record&& record) {
  submit_and_wait(recorded(std::forward<Record>(record)));
}

template <class Record, class Finish>
std::uint64_t Device::Impl::run(Record&& record, Finish&& finish) {
  if (!deferring()) {
    run(std::forward<Record>(record));
    finish();
    return 0;  // never pending
  }
  submit_deferred(recorded(std::forward<Record>(record)), std::function<void()>(std::forward<Finish>(finish)));
  return ++issued_;
}

}  // namespace gr::vulkan
