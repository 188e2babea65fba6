// The Vulkan RasterBackend: rasterize_forward through the device's own Frame,
// the texture lookups through raster/vulkan/texture.h, the cube maps'
// through raster/vulkan/cube_texture.h; interpolate, antialias and the
// G-buffer adjoint through one Frame of its own, into which each call loads
// the ops' G-buffer (Frame::load_gbuffer: nothing is kept between calls).
#include "raster/vulkan/backend.h"

#include <mutex>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/vulkan/cube_texture.h"
#include "raster/vulkan/frame.h"
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
  bool interpolate_forward(const raster::BarycentricInterpolateParams<float>& p, int width, int height, float* out,
                           float* out_da) const override {
    if (!p.tri_id) return false;
    std::lock_guard<std::mutex> lock(mutex_);
    Frame& f = load_for_interpolate(p, width, height);
    f.interpolate(p.attr, p.channels, out, p.diff, p.num_diff, out_da);
    return true;
  }
  bool interpolate_backward(const raster::BarycentricInterpolateParams<float>& p, int width, int height,
                            const float* grad_out, const float* grad_da,
                            const raster::BarycentricInterpolateGrads<float>& grads) const override {
    if (!p.tri_id) return false;
    std::lock_guard<std::mutex> lock(mutex_);
    Frame& f = load_for_interpolate(p, width, height);
    f.interpolate(p.attr, p.channels, nullptr, p.diff, p.num_diff, nullptr);
    // The G-buffer's gradient comes back as rast (H x W x 4) and rast_db;
    // its u, v go to grads.rast at the caller's stride, as the CPU adds them.
    const std::size_t plane = static_cast<std::size_t>(p.pixels) * 4;
    std::vector<float> g_rast(grads.rast ? plane : 0, 0.0f);
    f.interpolate_backward(grad_out, grad_da, grads.attr, grads.rast ? g_rast.data() : nullptr, grads.rast_db);
    if (grads.rast)
      for (std::int64_t q = 0; q < p.pixels; ++q) {
        grads.rast[p.rast_stride * q] += g_rast[4 * q];
        grads.rast[p.rast_stride * q + 1] += g_rast[4 * q + 1];
      }
    return true;
  }
  bool antialias_forward(const raster::AntialiasParams<float>& p, float* out) const override {
    std::lock_guard<std::mutex> lock(mutex_);
    load_for_antialias(p).antialias(p.image, p.channels, out, p.topology);
    return true;
  }
  bool antialias_backward(const raster::AntialiasParams<float>& p, const float* grad_out,
                          const raster::AntialiasGrads<float>& grads) const override {
    std::lock_guard<std::mutex> lock(mutex_);
    Frame& f = load_for_antialias(p);
    f.antialias(p.image, p.channels, nullptr, p.topology);  // the pairs, on the device
    f.antialias_backward(grad_out, grads.image, grads.clip);
    return true;
  }
  bool gbuffer_backward(const raster::BarycentricGBufferParams<float>& p, const float* grad_rast,
                        const float* grad_db, float* grad_clip) const override {
    if (!p.tri_id) return false;
    std::lock_guard<std::mutex> lock(mutex_);
    raster::RasterParams<float> rp{p.clip, p.num_vertices, p.tris, p.num_tris, {p.width, p.height}};
    GpuRasterOptions options;
    options.y_up = p.y_up;
    options.derivatives = grad_db != nullptr;
    Frame& f = frame();
    f.load_gbuffer(rp, options, p.tri_id, nullptr, 2, nullptr, nullptr);
    f.rasterize_backward(grad_rast, grad_db, grad_clip);
    return true;
  }

 private:
  Frame& frame() const {
    if (!frame_) frame_ = std::make_unique<Frame>(device_);
    return *frame_;
  }
  // Interpolation reads no clip positions: the frame gets the triangles and
  // as many (unread) vertices as the attributes have rows.
  Frame& load_for_interpolate(const raster::BarycentricInterpolateParams<float>& p, int width, int height) const {
    if (std::int64_t(width) * height != p.pixels)
      throw ValueError("vulkan interpolate: " + std::to_string(width) + " x " + std::to_string(height) +
                       " pixels, but the parameters hold " + std::to_string(p.pixels));
    zero_clip_.assign(static_cast<std::size_t>(4 * p.num_vertices), 0.0f);
    raster::RasterParams<float> rp{zero_clip_.data(), p.num_vertices, p.tris, p.num_tris, {width, height}};
    GpuRasterOptions options;
    options.derivatives = p.num_diff > 0;
    Frame& f = frame();
    f.load_gbuffer(rp, options, p.tri_id, p.rast, static_cast<int>(p.rast_stride), nullptr,
                   p.num_diff > 0 ? p.rast_db : nullptr);
    return f;
  }
  Frame& load_for_antialias(const raster::AntialiasParams<float>& p) const {
    raster::RasterParams<float> rp{p.clip, p.num_vertices, p.tris, p.num_tris, {p.width, p.height}};
    GpuRasterOptions options;
    options.y_up = p.y_up;
    Frame& f = frame();
    f.load_gbuffer(rp, options, p.tri_id, nullptr, 2, p.depth, nullptr);
    return f;
  }

  std::shared_ptr<Device> device_;
  // The G-buffer chain's frame, made at its first use; one call at a time.
  mutable std::mutex mutex_;
  mutable std::unique_ptr<Frame> frame_;
  mutable std::vector<float> zero_clip_;
};

}  // namespace

std::shared_ptr<const raster::RasterBackend> raster_backend(std::shared_ptr<Device> device) {
  if (!device) throw ValueError("vulkan raster_backend: no device");
  return std::make_shared<VulkanBackend>(std::move(device));
}

}  // namespace gr::vulkan
