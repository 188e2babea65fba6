// DepthPeelState: the double-buffered (depth, id) keys of a peeler (see depth_peel_state.h).
#include "raster/depth_peel_state.h"

#include <algorithm>
#include <string>

#include "autodiff/base/error.h"

namespace gr::raster {

void DepthPeelState::begin_layer(std::int64_t images, std::int64_t width, std::int64_t height) {
  const std::int64_t pixels = width * height;
  if (layers_ == 0 && id_[0].empty()) {
    images_ = images;
    pixels_ = pixels;
    for (int k = 0; k < 2; ++k) {
      id_[k].assign(static_cast<std::size_t>(images * pixels), 0);
      z_[k].assign(static_cast<std::size_t>(images * pixels), 0.0);
    }
  }
  if (images != images_ || pixels != pixels_)
    throw ValueError("DepthPeeler: layer " + std::to_string(layers_ + 1) + " has " + std::to_string(images) +
                     " images of " + std::to_string(width) + " x " + std::to_string(height) +
                     " pixels, but the layers before it had " + std::to_string(images_ * pixels_) + " pixels in all");
}

const std::int32_t* DepthPeelState::floor_id(std::int64_t b) const {
  return layers_ == 0 ? nullptr : id_[layers_ % 2].data() + b * pixels_;
}

const double* DepthPeelState::floor_z(std::int64_t b) const {
  return layers_ == 0 ? nullptr : z_[layers_ % 2].data() + b * pixels_;
}

void DepthPeelState::keep_ids(std::int64_t b, const std::int32_t* tri_id) {
  std::copy(tri_id, tri_id + pixels_, id_[next()].data() + b * pixels_);
}

template <class T>
void DepthPeelState::rasterize_image(RasterParams<T> p, std::int64_t b, std::int32_t* tri_id, T* uv, T* depth,
                                     RasterStats* stats, const RasterBackend* backend) {
  p.floor_id = floor_id(b);
  p.floor_z = floor_z(b);
  rasterize_forward_on(backend, p, tri_id, uv, depth, stats, key_z(b));
  keep_ids(b, tri_id);
}
template void DepthPeelState::rasterize_image<float>(RasterParams<float>, std::int64_t, std::int32_t*, float*,
                                                     float*, RasterStats*, const RasterBackend*);
template void DepthPeelState::rasterize_image<double>(RasterParams<double>, std::int64_t, std::int32_t*, double*,
                                                      double*, RasterStats*, const RasterBackend*);

void DepthPeelState::end_layer() { ++layers_; }

}  // namespace gr::raster
