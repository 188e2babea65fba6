// FramePool: least recently used among the frames nobody wants, then new
// ones, then least recently used among all.
#include "raster/vulkan/frame_pool.h"

#include <string>

#include "autodiff/base/error.h"

namespace gr::vulkan {

FramePool::FramePool(std::shared_ptr<Device> device, int capacity) : device_(std::move(device)), capacity_(capacity) {
  if (!device_) throw ValueError("vulkan FramePool: no device");
  if (capacity < 1) throw ValueError("vulkan FramePool: capacity must be at least 1, got " + std::to_string(capacity));
}

Frame& FramePool::take() {
  Slot* pick = nullptr;
  for (Slot& s : slots_)
    if ((s.serial == 0 || s.holder.expired()) && (!pick || s.used < pick->used)) pick = &s;
  if (!pick && frames() < capacity_) {
    slots_.push_back({std::make_unique<Frame>(device_), 0, {}, 0});
    pick = &slots_.back();
  }
  if (!pick)
    for (Slot& s : slots_)
      if (!pick || s.used < pick->used) pick = &s;
  pick->serial = 0;
  pick->holder.reset();
  pick->used = ++clock_;
  return *pick->frame;
}

void FramePool::tag(Frame& frame, std::uint64_t serial, std::weak_ptr<const void> holder) {
  for (Slot& s : slots_)
    if (s.frame.get() == &frame) {
      s.serial = serial;
      s.holder = std::move(holder);
      return;
    }
}

Uploads FramePool::triangle_uploads() const {
  Uploads sum;
  for (const Slot& s : slots_) {
    const Uploads u = s.frame->triangle_uploads();
    sum.uploads += u.uploads;
    sum.bytes += u.bytes;
  }
  return sum;
}

Frame* FramePool::find(std::uint64_t serial) {
  if (serial == 0) return nullptr;
  for (Slot& s : slots_)
    if (s.serial == serial && !s.holder.expired()) {
      s.used = ++clock_;
      return s.frame.get();
    }
  return nullptr;
}

}  // namespace gr::vulkan
