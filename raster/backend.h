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
#include <type_traits>

#include "raster/cube_texture.h"
#include "raster/rasterize.h"
#include "raster/texture.h"

namespace gr::raster {

class RasterBackend {
 public:
  virtual ~RasterBackend() = default;
  // e.g. "vulkan: NVIDIA H200".
  virtual std::string name() const = 0;
  // rasterize_forward(p, tri_id, uv, depth, nullptr, key_depth) (depth
  // peeling included) for what the backend covers; false when it does not
  // (the caller then runs the CPU kernel). p is validated; key_depth may be null.
  virtual bool rasterize_forward(const RasterParams<float>& p, std::int32_t* tri_id, float* uv, float* depth,
                                 double* key_depth) const = 0;
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

// rasterize_forward (raster/rasterize.h) on `backend` where it covers p
// (float32 clip positions), else on the CPU; stats only from the CPU kernel.
template <class T>
void rasterize_forward_on(const RasterBackend* backend, const RasterParams<T>& p, std::int32_t* tri_id, T* uv,
                          T* depth, RasterStats* stats = nullptr, double* key_depth = nullptr) {
  if constexpr (std::is_same_v<T, float>)
    if (backend && backend->rasterize_forward(p, tri_id, uv, depth, key_depth)) return;
  rasterize_forward(p, tri_id, uv, depth, stats, key_depth);
}

}  // namespace gr::raster
