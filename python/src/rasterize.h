// rasterize and the depth peeler in nvdiffrast's layout, over a Mesh.
#pragma once

#include <memory>
#include <vector>

#include "python/src/common.h"

namespace gr::vulkan {
class Device;  // raster/vulkan/device.h (built with the GPU path only)
}

namespace gr::python {

// The state of one DepthPeeler: per image, the previous layer's (depth, id)
// key, which the next layer must lie strictly behind.
struct PeelState {
  std::vector<std::int32_t> floor_id;  // images x H x W (0 before the first layer)
  std::vector<double> floor_z;
  int layers = 0;
};

// Scratch of one image of a call: the rasterizer's own outputs, the flipped
// positions and a gradient buffer, per dtype.
struct ImageScratch {
  enum Buffer { kUv, kDepth, kClip, kGrad, kBuffers };
  std::vector<std::int32_t> tri_id;
  std::vector<double> key_depth;
  template <class T>
  std::vector<T>& buffer(Buffer b);

 private:
  std::vector<float> f_[kBuffers];
  std::vector<double> d_[kBuffers];
};

// Per-context scratch (RasterizeCpuContext), one slot per image of a call,
// reused across calls so large buffers are allocated and page-faulted once.
// Images of a minibatch run in parallel, each on its own slot.
struct Context {
  std::vector<ImageScratch> images;
  // RasterizeVulkanContext: the device that rasterizes float32 positions
  // (null: the CPU kernels). Same G-buffer bits either way.
  std::shared_ptr<vulkan::Device> gpu;
  ImageScratch& image(std::int64_t b) { return images[static_cast<std::size_t>(b)]; }
  void reserve(std::int64_t count) {
    if (static_cast<std::int64_t>(images.size()) < count) images.resize(static_cast<std::size_t>(count));
  }
};

// rast, db: images x H x W x 4 (db may be 0). With a peel state, each image
// draws only what lies behind the state's key, which is then advanced.
void rasterize_forward(Context& ctx, const Mesh& mesh, int height, int width, Address rast, Address db,
                       PeelState* peel, int threads);
// grad_pos (zeroed by the caller, pos's shape) += the adjoint for the
// coverage in rast; grad_db may be 0.
void rasterize_backward(Context& ctx, const Mesh& mesh, int height, int width, Address rast, Address grad_rast,
                        Address grad_db, Address grad_pos, int threads);

}  // namespace gr::python
