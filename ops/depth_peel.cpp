// DepthPeeler: each layer is rasterize_layer with the previous layer's
// (depth, id) key as the floor.
#include "ops/depth_peel.h"

namespace gr {

DepthPeeler::DepthPeeler(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options)
    : clip_(clip), triangles_(triangles), options_(options) {
  detail::check_rasterize_inputs(clip, triangles, options, "DepthPeeler");
}

GBuffer DepthPeeler::rasterize_next_layer() {
  std::vector<double> key(static_cast<std::size_t>(options_.width) * options_.height);
  const bool first = layers_++ == 0;
  GBuffer gb = detail::rasterize_layer(clip_, triangles_, options_, first ? nullptr : floor_id_.data(),
                                       first ? nullptr : floor_z_.data(), key.data());
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  floor_id_.assign(id, id + key.size());
  floor_z_.swap(key);
  return gb;
}

}  // namespace gr
