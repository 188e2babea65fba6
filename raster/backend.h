// Where the raster kernels run: the CPU (no backend) or another device
// (raster/vulkan/backend.h gives a Vulkan one), the ops' execution context
// (RasterizeOptions::backend, TextureOptions::backend,
// CubeTextureOptions::backend). A backend gives
// rasterize_forward's G-buffer bit for bit, so everything that reads it (the
// rasterize adjoint, which runs on the CPU from tri_id, interpolate,
// antialias) is unchanged; texture and cube-map lookups give the CPU kernel's
// samples (within an ulp of float) and gradients (within 1e-5 of the largest).
#pragma once

#include <cstdint>
#include <string>

#include "raster/cube_texture.h"
#include "raster/rasterize.h"
#include "raster/texture.h"

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
  // texture_forward(p, out) / texture_backward(p, grad_out, grads) (raster/texture.h,
  // ACCUMULATED like it) for what the backend covers; false when it does not
  // (the caller then runs the CPU kernel). p is validated by the op.
  virtual bool texture_forward(const TextureParams<float>& /*p*/, float* /*out*/) const { return false; }
  virtual bool texture_backward(const TextureParams<float>& /*p*/, const float* /*grad_out*/,
                                const TextureGrads<float>& /*grads*/) const {
    return false;
  }
  // cube_texture_forward / cube_texture_backward (raster/cube_texture.h),
  // likewise: false when the backend does not cover them.
  virtual bool cube_texture_forward(const CubeTextureParams<float>& /*p*/, float* /*out*/) const { return false; }
  virtual bool cube_texture_backward(const CubeTextureParams<float>& /*p*/, const float* /*grad_out*/,
                                     const CubeTextureGrads<float>& /*grads*/) const {
    return false;
  }
};

}  // namespace gr::raster
