// interpolate in nvdiffrast's layout: attributes blended with a G-buffer's
// barycentrics, optionally with image-space derivatives of some channels.
#pragma once

#include <memory>
#include <vector>

#include "python/src/common.h"
#include "python/src/rasterize.h"

namespace gr::python {

// The inputs of one call, viewed and checked: rast [images, H, W, 4] float;
// attr [N, C] or [attr_images, N, C] of rast's dtype (attr_images 1 =
// broadcast, or images); tri [M, 3] int32; rast_db None or rast's shape;
// diff: channels in [0, C) to differentiate (rast_db required for any).
struct InterpolateArgs {
  InterpolateArgs(const pybind11::object& attr, const pybind11::object& rast, const pybind11::object& tri,
                  const pybind11::object& rast_db, std::vector<std::int32_t> diff, const char* op);
  Array attr, rast, tri, rast_db;
  std::int64_t attr_images = 1;
  std::int64_t vertices = 0, channels = 0;
  std::int64_t triangles = 0;
  std::int64_t images = 0, height = 0, width = 0;
  std::vector<std::int32_t> diff;  // channels to differentiate
};

// What a forward on the device left there for its adjoint, per image
// (raster::DeviceForward; null for an image run on the CPU).
struct InterpolateKept {
  std::vector<std::shared_ptr<const raster::DeviceForward>> images;
};

// ctx: None (the CPU kernels) or the context that made rast, whose device
// (a RasterizeVulkanContext's) then runs float32 calls, forward and adjoint;
// kept (may be null): rasterize_forward's handles for this very rast (and
// rast_db, tri), unchanged since: the device then reads its copy of them (a
// range mode image's with its range's triangles, raster::image_on_device).
// out: [images, H, W, C]; out_da: [images, H, W, 2 len(diff)], required
// with diff, else None. Returns what the device kept for the adjoint (null
// for a CPU call).
std::shared_ptr<InterpolateKept> interpolate_forward(Context* ctx, const pybind11::object& attr,
                                                     const pybind11::object& rast, const pybind11::object& tri,
                                                     const pybind11::object& rast_db, std::vector<std::int32_t> diff,
                                                     const pybind11::object& out, const pybind11::object& out_da,
                                                     int threads, const DeviceGBuffers* kept);
// grad_out: out's shape; grad_da: out_da's shape or None. Accumulates into
// grad_attr, grad_rast and grad_db (zeroed, shaped like attr, rast, rast_db;
// each None when not needed). forward (may be null): the forward's return,
// for these very inputs (the device then reads what that forward left there).
void interpolate_backward(Context* ctx, const pybind11::object& attr, const pybind11::object& rast,
                          const pybind11::object& tri, const pybind11::object& rast_db, std::vector<std::int32_t> diff,
                          const pybind11::object& grad_out, const pybind11::object& grad_da,
                          const pybind11::object& grad_attr, const pybind11::object& grad_rast,
                          const pybind11::object& grad_db, int threads, const DeviceGBuffers* kept,
                          const InterpolateKept* forward);

}  // namespace gr::python
