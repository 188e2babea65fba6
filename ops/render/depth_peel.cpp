// DepthPeeler: each layer is rasterize_layer (one image) or rasterize_images
// (a batch) with the previous layer's (depth, id) key as the floor.
#include "ops/render/depth_peel.h"

#include <algorithm>
#include <utility>

namespace gr {

DepthPeeler::DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options)
    : clip_(clip), triangles_(triangles), options_(options) {
  detail::check_rasterize_inputs(clip, triangles, options, "DepthPeeler");
}

DepthPeeler::DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                         detail::ImageBatch batch)
    : clip_(clip), triangles_(triangles), options_(options), batch_(std::move(batch)) {}

DepthPeeler DepthPeeler::instanced(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options) {
  return {clip, triangles, options, detail::check_instanced(clip, triangles, options, "DepthPeeler::instanced")};
}

DepthPeeler DepthPeeler::ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                                const RasterizeOptions& options) {
  return {clip, triangles, options, detail::check_ranges(clip, triangles, ranges, options, "DepthPeeler::ranges")};
}

GBuffer DepthPeeler::rasterize_next_layer() {
  const detail::PeelKey* floor = layers_++ == 0 ? nullptr : &floor_;
  detail::PeelKey key;
  GBuffer gb;
  if (batch_) {
    gb = detail::rasterize_images(clip_, triangles_, *batch_, options_, floor, &key, "DepthPeeler");
  } else {
    const std::int64_t pixels = std::int64_t(options_.width) * options_.height;
    key = {Tensor::empty({pixels}, DType::Int32), Tensor::empty({pixels}, DType::Float64)};
    gb = detail::rasterize_layer(clip_, triangles_, options_, floor ? floor->id.data<std::int32_t>() : nullptr,
                                 floor ? floor->z.data<double>() : nullptr, key.z.data<double>());
    // Read through the const data<T>(): rasterize recorded tri_id (autodiff/tape.h).
    const std::int32_t* id = std::as_const(gb.tri_id).data<std::int32_t>();
    std::copy(id, id + pixels, key.id.data<std::int32_t>());
  }
  floor_ = std::move(key);
  return gb;
}

}  // namespace gr
