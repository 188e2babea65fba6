#include "python/src/backend.h"

namespace gr::python {

bool CountedBackend::rasterize_forward(const raster::RasterParams<float>& p, std::int32_t* tri_id, float* uv,
                                       float* depth, double* key_depth) const {
  return count(inner_->rasterize_forward(p, tri_id, uv, depth, key_depth));
}
bool CountedBackend::texture_forward(const raster::TextureParams<float>& p, float* out) const {
  return count(inner_->texture_forward(p, out));
}
bool CountedBackend::texture_backward(const raster::TextureParams<float>& p, const float* grad_out,
                                      const raster::TextureGrads<float>& grads) const {
  return count(inner_->texture_backward(p, grad_out, grads));
}
bool CountedBackend::cube_texture_forward(const raster::CubeTextureParams<float>& p, float* out) const {
  return count(inner_->cube_texture_forward(p, out));
}
bool CountedBackend::cube_texture_backward(const raster::CubeTextureParams<float>& p, const float* grad_out,
                                           const raster::CubeTextureGrads<float>& grads) const {
  return count(inner_->cube_texture_backward(p, grad_out, grads));
}
bool CountedBackend::interpolate_forward(const raster::BarycentricInterpolateParams<float>& p, int width, int height,
                                         float* out, float* out_da) const {
  return count(inner_->interpolate_forward(p, width, height, out, out_da));
}
bool CountedBackend::interpolate_backward(const raster::BarycentricInterpolateParams<float>& p, int width,
                                          int height, const float* grad_out, const float* grad_da,
                                          const raster::BarycentricInterpolateGrads<float>& grads) const {
  return count(inner_->interpolate_backward(p, width, height, grad_out, grad_da, grads));
}
bool CountedBackend::antialias_forward(const raster::AntialiasParams<float>& p, float* out) const {
  return count(inner_->antialias_forward(p, out));
}
bool CountedBackend::antialias_backward(const raster::AntialiasParams<float>& p, const float* grad_out,
                                        const raster::AntialiasGrads<float>& grads) const {
  return count(inner_->antialias_backward(p, grad_out, grads));
}
bool CountedBackend::gbuffer_backward(const raster::BarycentricGBufferParams<float>& p, const float* grad_rast,
                                      const float* grad_db, float* grad_clip) const {
  return count(inner_->gbuffer_backward(p, grad_rast, grad_db, grad_clip));
}

}  // namespace gr::python
