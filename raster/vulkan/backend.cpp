// The Vulkan RasterBackend: rasterize_forward through the device's own Frame,
// the texture lookups through raster/vulkan/texture.h, the cube maps'
// through raster/vulkan/cube_texture.h.
#include "raster/vulkan/backend.h"

#include "autodiff/base/error.h"
#include "raster/vulkan/cube_texture.h"
#include "raster/vulkan/rasterize.h"
#include "raster/vulkan/texture.h"

namespace gr::vulkan {
namespace {

class VulkanBackend : public raster::RasterBackend {
 public:
  explicit VulkanBackend(std::shared_ptr<Device> device) : device_(std::move(device)) {}
  std::string name() const override { return "vulkan: " + device_->info().name; }
  bool rasterize_forward(const raster::RasterParams<float>& p, std::int32_t* tri_id, float* uv, float* depth,
                         double* key_depth) const override {
    vulkan::rasterize_forward(*device_, p, tri_id, uv, depth, {}, nullptr, key_depth);
    return true;
  }
  bool texture_forward(const raster::TextureParams<float>& p, float* out) const override {
    vulkan::texture_forward(*device_, p, out);
    return true;
  }
  bool texture_backward(const raster::TextureParams<float>& p, const float* grad_out,
                        const raster::TextureGrads<float>& grads) const override {
    vulkan::texture_backward(*device_, p, grad_out, grads);
    return true;
  }
  bool cube_texture_forward(const raster::CubeTextureParams<float>& p, float* out) const override {
    vulkan::cube_texture_forward(*device_, p, out);
    return true;
  }
  bool cube_texture_backward(const raster::CubeTextureParams<float>& p, const float* grad_out,
                             const raster::CubeTextureGrads<float>& grads) const override {
    vulkan::cube_texture_backward(*device_, p, grad_out, grads);
    return true;
  }

 private:
  std::shared_ptr<Device> device_;
};

}  // namespace

std::shared_ptr<const raster::RasterBackend> raster_backend(std::shared_ptr<Device> device) {
  if (!device) throw ValueError("vulkan raster_backend: no device");
  return std::make_shared<VulkanBackend>(std::move(device));
}

}  // namespace gr::vulkan
