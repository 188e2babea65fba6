// The Frames in which a RasterBackend keeps the G-buffers it made on the
// device (raster/vulkan/backend.h): at most `capacity` of them, each tagged
// with the serial of the G-buffer it holds (0: none kept) and the handle that
// wants it (the backend loads uploaded G-buffers into a frame of its own). A new G-buffer takes a
// frame nobody wants any more (untagged, or its handle gone), else a new one
// below capacity, else the least recently used (whose G-buffer is let go:
// its handle's calls then upload it again). One caller at a time (the
// backend locks).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "raster/vulkan/device.h"
#include "raster/vulkan/frame.h"

namespace gr::vulkan {

class FramePool {
 public:
  FramePool(std::shared_ptr<Device> device, int capacity);

  // A frame for a new G-buffer, untagged until tag(): its old G-buffer is gone.
  Frame& take();
  // Marks `frame` (from take()) as holding serial's G-buffer for `holder`.
  void tag(Frame& frame, std::uint64_t serial, std::weak_ptr<const void> holder);
  // The frame still holding serial's G-buffer (now the most recently used), or null.
  Frame* find(std::uint64_t serial);
  int frames() const { return static_cast<int>(slots_.size()); }
  // The triangle lists its frames uploaded (Frame::triangle_uploads), summed.
  Uploads triangle_uploads() const;
  int capacity() const { return capacity_; }
  // Lets the pool hold `capacity` frames from now on, if that is more (never fewer).
  void reserve(int capacity) { capacity_ = capacity > capacity_ ? capacity : capacity_; }

 private:
  struct Slot {
    std::unique_ptr<Frame> frame;
    std::uint64_t serial = 0;
    std::weak_ptr<const void> holder;
    std::uint64_t used = 0;  // the clock at its last take or find
  };
  std::shared_ptr<Device> device_;
  int capacity_;
  std::vector<Slot> slots_;
  std::uint64_t clock_ = 0;
};

}  // namespace gr::vulkan
