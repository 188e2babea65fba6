// Where the G-buffer is made: the CPU kernel (no backend) or another device
// (raster/vulkan/backend.h gives a Vulkan one). A backend gives
// rasterize_forward's G-buffer bit for bit, so everything that reads it (the
// rasterize adjoint, which runs on the CPU from tri_id, interpolate,
// antialias) is unchanged: the ops take one as their execution context
// (RasterizeOptions::backend) without changing any result.
#pragma once

#include <cstdint>
#include <string>

#include "raster/rasterize.h"

namespace gr::raster {

class RasterBackend {
 public:
  virtual ~RasterBackend() = default;
  // e.g. "vulkan: NVIDIA H200".
  virtual std::string name() const = 0;
  // rasterize_forward(p, tri_id, uv, depth) for what the backend covers; false
  // when it does not (the caller then runs the CPU kernel). p is validated.
  virtual bool rasterize_forward(const RasterParams<float>& p, std::int32_t* tri_id, float* uv,
                                 float* depth) const = 0;
};

}  // namespace gr::raster
