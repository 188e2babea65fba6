// Tape op over raster::rasterize_forward / rasterize_backward.
#include "ops/rasterize.h"

#include "autodiff/tape.h"
#include "ops/broadcast.h"

namespace gr {

GBuffer rasterize(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options) {
  detail::check_clip_and_triangles(clip, triangles, "rasterize");
  const raster::RasterSettings settings{options.width, options.height, options.cull, options.front_to_back};
  const std::int64_t h = options.height, w = options.width;
  if (h <= 0 || w <= 0 || h > 16384 || w > 16384 || h * w > (std::int64_t(1) << 28))
    throw ValueError("rasterize: image size " + std::to_string(w) + " x " + std::to_string(h) +
                     " is outside 1..16384 per side (at most 2^28 pixels)");
  GBuffer gb;
  gb.tri_id = Tensor::empty({h, w}, DType::Int32);
  gb.uv = Tensor::empty({h, w, 2}, clip.dtype());
  gb.depth = Tensor::empty({h, w}, clip.dtype());
  dispatch_float(clip.dtype(), "rasterize", [&](auto tag) {
    using T = decltype(tag);
    raster::rasterize_forward(clip.data<T>(), clip.size(0), triangles.data<std::int32_t>(), triangles.size(0),
                              settings, gb.tri_id.data<std::int32_t>(), gb.uv.data<T>(), gb.depth.data<T>(),
                              &gb.stats);
  });
  if (should_record({clip})) {
    record("rasterize", {clip}, {&gb.uv, &gb.depth},
           [clip, triangles, settings, tri_id = gb.tri_id](AdjointContext& ctx) {
             const Tensor& g_uv = ctx.grad_output(0);
             const Tensor& g_depth = ctx.grad_output(1);
             Tensor uv_grad = g_uv.defined() ? g_uv : Tensor::zeros({tri_id.size(0), tri_id.size(1), 2}, clip.dtype());
             Tensor g = Tensor::zeros(clip.shape(), clip.dtype());
             dispatch_float(clip.dtype(), "rasterize", [&](auto tag) {
               using T = decltype(tag);
               raster::rasterize_backward(clip.data<T>(), clip.size(0), triangles.data<std::int32_t>(),
                                          triangles.size(0), settings, tri_id.data<std::int32_t>(),
                                          uv_grad.data<T>(), g_depth.defined() ? g_depth.data<T>() : nullptr,
                                          g.data<T>());
             });
             ctx.accumulate(0, g);
           });
  }
  return gb;
}

}  // namespace gr
