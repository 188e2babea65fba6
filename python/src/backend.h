// Where a call of the binding runs its kernels: on the device of a
// RasterizeVulkanContext (Context::backend) for float32, image by image
// through raster::RasterBackend's virtuals, else on the CPU kernels.
// gradraster.torch decides which context a call gets (the one that made its
// rast or uv: docs/python.md, "Vulkan"); a backend that declines a call
// (returns false) leaves it to the CPU kernel.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "python/src/rasterize.h"
#include "raster/backend.h"
#include "raster/image_batch.h"

namespace gr::python {

// A backend that counts the calls it ran (those its inner backend did not
// decline), per image: Context.device_calls, by which a program (and the
// tests) can see that its ops ran on the device. It forwards every virtual
// of raster::RasterBackend; one added there must be forwarded here too.
class CountedBackend : public raster::RasterBackend {
 public:
  explicit CountedBackend(std::shared_ptr<const raster::RasterBackend> inner) : inner_(std::move(inner)) {}
  std::int64_t calls() const { return calls_.load(); }

  std::string name() const override { return inner_->name(); }
  bool rasterize_forward(const raster::RasterParams<float>& p, std::int32_t* tri_id, float* uv, float* depth,
                         double* key_depth) const override;
  bool texture_forward(const raster::TextureParams<float>& p, float* out) const override;
  bool texture_backward(const raster::TextureParams<float>& p, const float* grad_out,
                        const raster::TextureGrads<float>& grads) const override;
  bool cube_texture_forward(const raster::CubeTextureParams<float>& p, float* out) const override;
  bool cube_texture_backward(const raster::CubeTextureParams<float>& p, const float* grad_out,
                             const raster::CubeTextureGrads<float>& grads) const override;
  bool interpolate_forward(const raster::BarycentricInterpolateParams<float>& p, int width, int height, float* out,
                           float* out_da) const override;
  bool interpolate_backward(const raster::BarycentricInterpolateParams<float>& p, int width, int height,
                            const float* grad_out, const float* grad_da,
                            const raster::BarycentricInterpolateGrads<float>& grads) const override;
  bool antialias_forward(const raster::AntialiasParams<float>& p, float* out) const override;
  bool antialias_backward(const raster::AntialiasParams<float>& p, const float* grad_out,
                          const raster::AntialiasGrads<float>& grads) const override;
  bool gbuffer_backward(const raster::BarycentricGBufferParams<float>& p, const float* grad_rast,
                        const float* grad_db, float* grad_clip) const override;

 private:
  bool count(bool ran) const {
    if (ran) ++calls_;
    return ran;
  }
  std::shared_ptr<const raster::RasterBackend> inner_;
  mutable std::atomic<std::int64_t> calls_{0};
};

// ctx's backend for T = float (null: none, a CPU context, no context, float64).
template <class T>
const raster::RasterBackend* backend_for(const Context* ctx) {
  if constexpr (std::is_same_v<T, float>) return ctx ? ctx->backend.get() : nullptr;
  return nullptr;
}

// The int32 ids (H*W, 0 = background) of rast's id channel (H*W*4, ids
// already checked to be integers in [0, triangles]), what a backend reads.
template <class T>
void rast_ids(const T* rast, std::int64_t pixels, std::vector<std::int32_t>* ids) {
  ids->resize(static_cast<std::size_t>(pixels));
  for (std::int64_t q = 0; q < pixels; ++q) (*ids)[q] = static_cast<std::int32_t>(rast[4 * q + 3]);
}

// body(b) for every image: in parallel on the CPU; in image order with a
// backend, which runs one call at a time and is parallel inside (its lock
// is never awaited inside a parallel region).
template <class F>
void for_each_image_on(const raster::RasterBackend* backend, std::int64_t images, F&& body) {
  if (!backend) return raster::for_each_image(images, body);
  for (std::int64_t b = 0; b < images; ++b) body(b);
}

}  // namespace gr::python
