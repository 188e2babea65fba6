// DepthPeeler: each layer is rasterize_layer (one image) or rasterize_images
// (a batch) with the previous layer's (depth, id) key as the floor.
#include "ops/depth_peel.h"

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
    key.z.resize(static_cast<std::size_t>(options_.width) * options_.height);
    gb = detail::rasterize_layer(clip_, triangles_, options_, floor ? floor->id.data() : nullptr,
                                 floor ? floor->z.data() : nullptr, key.z.data());
    const std::int32_t* id = gb.tri_id.data<std::int32_t>();
    key.id.assign(id, id + key.z.size());
  }
  floor_ = std::move(key);
  return gb;
}

}  // namespace gr
