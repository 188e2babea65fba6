// rasterize and the depth peeler in nvdiffrast's layout, over a Mesh.
#pragma once

#include <memory>
#include <vector>

#include "python/src/common.h"
#include "raster/backend.h"
#include "raster/depth_peel_state.h"

namespace gr::vulkan {
class Device;  // raster/vulkan/device.h (built with the GPU path only)
}

namespace gr::python {

struct DeviceGBuffers;  // python/src/backend.h

// Scratch of one image of a call: the coverage (tri_id), a depth buffer
// (antialias, a device's G-buffer), a gradient buffer and a uv buffer (a
// device's G-buffer), per dtype. (The kernels read the caller's positions:
// they run with y_up, nvdiffrast's row 0 at the bottom.)
struct ImageScratch {
  enum Buffer { kDepth, kGrad, kUv, kBuffers };
  std::vector<std::int32_t> tri_id;
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
  // RasterizeVulkanContext: the device that runs float32 calls (null: the
  // CPU kernels), and it as the kernels' backend (python/src/backend.h):
  // rasterize (the same G-buffer bits, kept there) and its adjoint, and
  // interpolate, antialias and texture when handed this context.
  std::shared_ptr<vulkan::Device> gpu;
  std::shared_ptr<const raster::RasterBackend> backend;
  // The per-image calls the device ran (Context.device_calls; counted).
  std::int64_t device_calls = 0;
  // frames=None: the backend's pool grows to the largest minibatch rasterized (keep_gbuffers).
  bool grow_frames = false;
  ImageScratch& image(std::int64_t b) { return images[static_cast<std::size_t>(b)]; }
  void reserve(std::int64_t count) {
    if (static_cast<std::int64_t>(images.size()) < count) images.resize(static_cast<std::size_t>(count));
  }
  // The gradient buffers (kGrad) of images [0, count), for raster::sum_in_image_order.
  template <class T>
  std::vector<const T*> grads(std::int64_t count) {
    std::vector<const T*> out;
    for (std::int64_t b = 0; b < count; ++b) out.push_back(image(b).buffer<T>(ImageScratch::kGrad).data());
    return out;
  }
};

// pos, tri, ranges: a Mesh. rast, db (None: not wanted): [images, H, W, 4]
// of pos's dtype, 1 <= H, W <= raster::kMaxSide (the resolution). With a peel
// state (a DepthPeeler's), each image draws only what lies behind the state's
// key, which is then advanced. On ctx's device for float32
// (RasterizeVulkanContext: the whole G-buffer, the CPU kernels' bits), which
// keeps it: returns the images' handles (null: a CPU call).
std::shared_ptr<DeviceGBuffers> rasterize_forward(Context& ctx, const pybind11::object& pos,
                                                  const pybind11::object& tri, Ranges ranges,
                                                  const pybind11::object& rast, const pybind11::object& db,
                                                  raster::DepthPeelState* peel, int threads);
// grad_pos (zeroed by the caller, pos's shape) += the adjoint for the
// coverage in rast; grad_rast: rast's shape; grad_db: None or rast's shape.
// On ctx's device for float32 (RasterizeVulkanContext), else the CPU kernel;
// kept (may be null): rasterize_forward's handles for this very rast, pos and
// tri, unchanged since (the device then reads its copy of the coverage).
void rasterize_backward(Context& ctx, const pybind11::object& pos, const pybind11::object& tri, Ranges ranges,
                        const pybind11::object& rast, const pybind11::object& grad_rast,
                        const pybind11::object& grad_db, const pybind11::object& grad_pos, int threads,
                        const DeviceGBuffers* kept);

}  // namespace gr::python
