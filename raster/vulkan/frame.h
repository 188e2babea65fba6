// A render kept on a Vulkan device: one mesh's clip positions and triangles,
// the G-buffer rasterized from them, and the buffers of the ops run on it, so
// that interpolate (and its adjoint) read the G-buffer without a round trip.
// Host arrays cross at each call: inputs are uploaded, and outputs are
// downloaded only where the caller passes a pointer. Each call returns where
// its time went (device timestamps; docs/gpu.md).
//
// Results: rasterize gives the CPU kernel's G-buffer bit for bit; interpolate
// the CPU kernel's values (the same double expressions: equal or within an
// ulp of float); the adjoint's sums are taken in 64-bit fixed point (exact
// and order-independent, so bit-identical run to run; resolution about
// 2^-61 x pixels x the largest contribution), within 1e-12 of the CPU's
// double sums relative to the largest gradient. antialias gives the CPU
// kernel's pairs (the same silhouette walk in double) and blends, bit for
// bit; its adjoint sums the edge vertices' screen gradients in fixed point
// (the same resolution) before the projection adjoint.
//
// A Frame is used by one thread at a time; Frames on one device share its
// queue (calls are serialized).
#pragma once

#include <cstdint>
#include <memory>

#include "raster/rasterize.h"
#include "raster/vulkan/device.h"
#include "raster/vulkan/rasterize.h"

namespace gr::vulkan {

class Frame {
 public:
  explicit Frame(std::shared_ptr<Device> device);
  ~Frame();
  Frame(const Frame&) = delete;
  Frame& operator=(const Frame&) = delete;

  // rasterize_forward (raster/vulkan/rasterize.h); the G-buffer stays on the
  // device and is downloaded into the arrays given (each may be null).
  // Checks p as the CPU op does (ValueError / IndexError naming the problem):
  // image size, indices in range, finite clip; and what the shaders' 32-bit
  // indices allow (at most 2^31 / 4 vertices, 2^31 / 3 triangles).
  // pass_ms: clear, project, depth pass, id pass, resolve.
  GpuTimes rasterize(const raster::RasterParams<float>& p, const GpuRasterOptions& options = {},
                     std::int32_t* tri_id = nullptr, float* uv = nullptr, float* depth = nullptr);

  // interpolate_forward (raster/interpolate.h, image form, zeros on the
  // background) of attr (num_vertices x channels) over the last rasterize's
  // G-buffer and clip positions; out (H x W x channels) if not null.
  GpuTimes interpolate(const float* attr, std::int64_t channels, bool perspective = true, float* out = nullptr);

  // The adjoint of the last interpolate for grad_out (H x W x channels),
  // ACCUMULATED (+=) into grad_attr (N x C), grad_clip (N x 4) and grad_uv
  // (H x W x 2), each may be null. pass_ms: magnitudes, sums, finish.
  GpuTimes interpolate_backward(const float* grad_out, float* grad_attr, float* grad_clip, float* grad_uv);

  // The adjoint of the last rasterize (raster::rasterize_backward, for its
  // coverage) for grad_uv (H x W x 2) and grad_depth (H x W, may be null),
  // ACCUMULATED (+=) into grad_clip (N x 4). pass_ms: magnitudes, sums, finish.
  GpuTimes rasterize_backward(const float* grad_uv, const float* grad_depth, float* grad_clip);

  // antialias_forward (raster/antialias.h) of image (H x W x channels) over
  // the last rasterize's G-buffer, clip positions and triangles; out (H x W x
  // channels) if not null. The edge topology (build_edge_topology of the
  // triangles, no welding) is built on the host and uploaded on the first
  // call after a rasterize whose triangles differ from the last ones; else
  // the device's copy is reused. The pairs stay on the device for the
  // adjoint. image null: the last interpolate's output, which stays on the
  // device (its channel count must be `channels`). pass_ms: pairs, blend.
  GpuTimes antialias(const float* image, int channels, float* out = nullptr);

  // The adjoint of the last antialias for grad_out (H x W x channels),
  // ACCUMULATED (+=) into grad_image (H x W x channels) and grad_clip (N x 4),
  // each may be null. pass_ms: image gradient and magnitudes, sums, finish.
  GpuTimes antialias_backward(const float* grad_out, float* grad_image, float* grad_clip);

 private:
  struct State;
  std::shared_ptr<Device> device_;
  std::unique_ptr<State> state_;
};

}  // namespace gr::vulkan
