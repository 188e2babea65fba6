// visibility_antialias: antialias's op with every visibility boundary blended.
#include "ops/render/visibility_antialias.h"

namespace gr {

Tensor visibility_antialias(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                            const VisibilityAntialiasOptions& options) {
  AntialiasOptions o;
  o.topology = options.topology;
  o.pos_gradient_boost = options.pos_gradient_boost;
  o.visibility = true;
  o.visibility_stats = options.stats;
  return antialias(image, gbuffer, clip, triangles, o);
}

}  // namespace gr
