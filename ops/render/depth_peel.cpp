// DepthPeeler: each layer is rasterize_layer (one image) or rasterize_images
// (a batch) with the previous layer's (depth, id) key as the floor, kept by
// raster::DepthPeelState.
#include "ops/render/depth_peel.h"

#include <utility>

namespace gr {

DepthPeeler::DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options)
    : clip_(clip), triangles_(triangles), options_(options) {
  detail::check_rasterize_inputs(clip, triangles, options, "DepthPeeler");
}

DepthPeeler::DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                         raster::ImageBatch batch)
    : clip_(clip), triangles_(triangles), options_(options), batch_(std::move(batch)) {}

DepthPeeler DepthPeeler::instanced(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options) {
  return {clip, triangles, options, detail::check_instanced(clip, triangles, options, "DepthPeeler::instanced")};
}

DepthPeeler DepthPeeler::ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                                const RasterizeOptions& options) {
  return {clip, triangles, options, detail::check_ranges(clip, triangles, ranges, options, "DepthPeeler::ranges")};
}

GBuffer DepthPeeler::rasterize_next_layer() {
  if (batch_) return detail::rasterize_images(clip_, triangles_, *batch_, options_, &peel_, "DepthPeeler");
  peel_.begin_layer(1, options_.width, options_.height);
  GBuffer gb = detail::rasterize_layer(clip_, triangles_, options_, peel_.floor_id(0), peel_.floor_z(0),
                                       peel_.key_z(0));
  // Read through the const data<T>(): rasterize recorded tri_id (autodiff/tape.h).
  peel_.keep_ids(0, std::as_const(gb.tri_id).data<std::int32_t>());
  peel_.end_layer();
  return gb;
}

}  // namespace gr
