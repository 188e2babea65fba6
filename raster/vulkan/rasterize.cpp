// rasterize_forward on a device: through a Frame that the device keeps for
// these calls (so repeated calls reuse its buffers). The passes: frame.cpp.
#include "raster/vulkan/rasterize.h"

#include <memory>

#include "raster/vulkan/frame.h"
#include "raster/vulkan/internal/context.h"

namespace gr::vulkan {

void rasterize_forward(Device& device, const raster::RasterParams<float>& p, std::int32_t* tri_id, float* uv,
                       float* depth, const GpuRasterOptions& options, GpuTimes* times, double* key_depth) {
  Device::Impl& dev = device.impl();
  std::shared_ptr<Frame> frame;
  {
    std::lock_guard<std::mutex> lock(dev.mutex);
    frame = std::static_pointer_cast<Frame>(dev.default_frame);
  }
  if (!frame) {
    // The device owns this frame, so the frame must not own the device: an
    // aliasing pointer with no owner.
    auto made = std::make_shared<Frame>(std::shared_ptr<Device>(std::shared_ptr<Device>(), &device));
    std::lock_guard<std::mutex> lock(dev.mutex);
    if (!dev.default_frame) dev.default_frame = made;
    frame = std::static_pointer_cast<Frame>(dev.default_frame);
  }
  const GpuTimes t = frame->rasterize_coverage(p, options, tri_id, uv, depth, key_depth);
  if (times) *times = t;
}

}  // namespace gr::vulkan
