// Tape op over raster::rasterize_forward / rasterize_backward.
#include "ops/rasterize.h"

#include <type_traits>

#include "autodiff/tape.h"
#include "ops/check.h"
#include "raster/triangle_groups.h"

namespace gr {
namespace {

// The kernels' view of validated tensors (forward and adjoint alike).
template <class T>
raster::RasterParams<T> params(const Tensor& clip, const Tensor& triangles, const raster::RasterSettings& settings) {
  return {clip.data<T>(), clip.size(0), triangles.data<std::int32_t>(), triangles.size(0), settings};
}

}  // namespace

GBuffer rasterize(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options) {
  detail::check_rasterize_inputs(clip, triangles, options, "rasterize");
  return detail::rasterize_layer(clip, triangles, options, nullptr, nullptr, nullptr);
}

namespace detail {

void check_rasterize_inputs(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                            const char* op) {
  check_image_size(options.width, options.height, op);
  check_clip_and_triangles(clip, triangles, op);
  check_finite(clip, op, "clip");
}

GBuffer rasterize_layer(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                        const std::int32_t* floor_id, const double* floor_z, double* key_depth) {
  const char* op = "rasterize";
  const raster::RasterSettings settings{options.width, options.height, options.cull, options.front_to_back};
  const std::int64_t h = options.height, w = options.width;
  GBuffer gb;
  gb.clip = clip;
  gb.triangles = triangles;
  gb.tri_id = Tensor::empty({h, w}, DType::Int32);
  gb.uv = Tensor::empty({h, w, 2}, clip.dtype());
  gb.depth = Tensor::empty({h, w}, clip.dtype());
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    raster::RasterParams<T> p = params<T>(clip, triangles, settings);
    p.floor_id = floor_id;
    p.floor_z = floor_z;
    if constexpr (std::is_same_v<T, float>)
      if (options.backend && !key_depth &&
          options.backend->rasterize_forward(p, gb.tri_id.data<std::int32_t>(), gb.uv.data<T>(), gb.depth.data<T>()))
        return;
    raster::rasterize_forward(p, gb.tri_id.data<std::int32_t>(), gb.uv.data<T>(), gb.depth.data<T>(), &gb.stats,
                              key_depth);
  });
  if (should_record({clip})) {
    gb.groups = std::make_shared<raster::TriangleGroups>(gb.tri_id.data<std::int32_t>(),
                                                         std::make_shared<Tensor>(gb.tri_id));
    // The backward trusts what the forward checked: same clip, triangles and
    // settings, and the forward's own tri_id (listed after clip so that
    // backward() refuses them written in place since; they get no gradient).
    record("rasterize", {clip, triangles, gb.tri_id}, {&gb.uv, &gb.depth},
           [clip, triangles, settings, tri_id = gb.tri_id, groups = gb.groups](AdjointContext& ctx) {
             const Tensor& g_uv = ctx.grad_output(0);
             const Tensor& g_depth = ctx.grad_output(1);
             Tensor uv_grad = g_uv.defined() ? g_uv : Tensor::zeros({tri_id.size(0), tri_id.size(1), 2}, clip.dtype());
             Tensor g = Tensor::zeros(clip.shape(), clip.dtype());
             dispatch_float(clip.dtype(), "rasterize", [&](auto tag) {
               using T = decltype(tag);
               raster::rasterize_backward(params<T>(clip, triangles, settings), tri_id.data<std::int32_t>(),
                                          uv_grad.data<T>(), g_depth.defined() ? g_depth.data<T>() : nullptr,
                                          g.data<T>(), groups.get());
             });
             ctx.accumulate(0, g);
           });
  }
  return gb;
}

}  // namespace detail
}  // namespace gr
