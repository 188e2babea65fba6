// Tape op over raster::interpolate_forward / interpolate_backward.
#include "ops/interpolate.h"

#include "autodiff/tape.h"
#include "ops/broadcast.h"
#include "raster/rasterize_setup.h"  // detail::check_finite
#include "raster/interpolate.h"

namespace gr {
namespace {

// Checks shared by the image and fragment forms.
void check_attributes(const Tensor& attributes, const Tensor& clip, const Tensor& triangles) {
  detail::check_clip_and_triangles(clip, triangles, "interpolate");
  detail::check_float(attributes, "interpolate", "attributes");
  if (attributes.rank() != 2 || attributes.size(0) != clip.size(0))
    throw ShapeError("interpolate: argument 'attributes' must have shape [N, C] with N = " +
                     std::to_string(clip.size(0)) + " vertices (rows of clip), got " + attributes.describe());
  if (attributes.dtype() != clip.dtype())
    throw DTypeError("interpolate: attributes " + attributes.describe() + " and clip " + clip.describe() +
                     " must have the same dtype");
  // NaN/Inf attributes would silently spread over every pixel of their triangles.
  dispatch_float(attributes.dtype(), "interpolate", [&](auto tag) {
    using T = decltype(tag);
    raster::detail::check_finite(attributes.data<T>(), attributes.numel(), "attributes", "interpolate");
  });
}

}  // namespace

Tensor interpolate(const Tensor& attributes, const Tensor& clip, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options) {
  check_attributes(attributes, clip, triangles);
  if (!gbuffer.tri_id.defined() || gbuffer.tri_id.dtype() != DType::Int32 || gbuffer.tri_id.rank() != 2)
    throw ShapeError("interpolate: argument 'gbuffer' has no [H, W] int32 tri_id (pass the result of rasterize)");
  const std::int64_t h = gbuffer.tri_id.size(0), w = gbuffer.tri_id.size(1), c = attributes.size(1);
  if (gbuffer.uv.shape() != Shape{h, w, 2} || gbuffer.uv.dtype() != clip.dtype())
    throw ShapeError("interpolate: gbuffer.uv " + gbuffer.uv.describe() + " does not match tri_id " +
                     gbuffer.tri_id.describe() + " and clip dtype");
  Tensor background = options.background;
  if (background.defined()) {
    detail::check_float(background, "interpolate", "background");
    if (background.numel() != c || background.dtype() != attributes.dtype())
      throw ShapeError("interpolate: background " + background.describe() + " must hold C = " + std::to_string(c) +
                       " values of the attributes' dtype");
    // A NaN/Inf background would fill every uncovered pixel with it.
    dispatch_float(background.dtype(), "interpolate", [&](auto tag) {
      using T = decltype(tag);
      raster::detail::check_finite(background.data<T>(), background.numel(), "background", "interpolate");
    });
  }
  Tensor out = Tensor::empty({h, w, c}, attributes.dtype());
  const bool perspective = options.perspective;
  dispatch_float(attributes.dtype(), "interpolate", [&](auto tag) {
    using T = decltype(tag);
    raster::interpolate_forward(attributes.data<T>(), attributes.size(0), c, clip.data<T>(),
                                triangles.data<std::int32_t>(), triangles.size(0),
                                gbuffer.tri_id.data<std::int32_t>(), gbuffer.uv.data<T>(), int(w), int(h),
                                perspective, background.defined() ? background.data<T>() : nullptr, out.data<T>());
  });
  const Tensor& uv = gbuffer.uv;
  if (should_record({attributes, clip, uv})) {
    record("interpolate", {attributes, clip, uv}, {&out},
           [attributes, clip, triangles, tri_id = gbuffer.tri_id, uv = uv.detach(), perspective](AdjointContext& ctx) {
             const std::int64_t h = tri_id.size(0), w = tri_id.size(1);
             Tensor g_attr = ctx.needs_grad(0) ? Tensor::zeros(attributes.shape(), attributes.dtype()) : Tensor();
             Tensor g_clip = ctx.needs_grad(1) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
             Tensor g_uv = ctx.needs_grad(2) ? Tensor::zeros(uv.shape(), uv.dtype()) : Tensor();
             dispatch_float(attributes.dtype(), "interpolate", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::interpolate_backward(attributes.data<T>(), attributes.size(0), attributes.size(1),
                                            clip.data<T>(), triangles.data<std::int32_t>(), triangles.size(0),
                                            tri_id.data<std::int32_t>(), uv.data<T>(), int(w), int(h), perspective,
                                            ctx.grad_output().data<T>(), ptr(g_attr), ptr(g_clip), ptr(g_uv));
             });
             if (g_attr.defined()) ctx.accumulate(0, g_attr);
             if (g_clip.defined()) ctx.accumulate(1, g_clip);
             if (g_uv.defined()) ctx.accumulate(2, g_uv);
           });
  }
  return out;
}

Tensor interpolate(const Tensor& attributes, const Tensor& clip, const Fragments& fragments, const Tensor& triangles,
                   const InterpolateOptions& options) {
  check_attributes(attributes, clip, triangles);
  if (options.background.defined())
    throw ValueError("interpolate: options.background has no meaning for fragments (every fragment is covered); "
                     "pass it to to_image");
  const std::int64_t n = fragments.count(), c = attributes.size(1);
  if (!fragments.tri_id.defined() || fragments.tri_id.dtype() != DType::Int32 || fragments.tri_id.shape() != Shape{n})
    throw ShapeError("interpolate: argument 'fragments' has no [F] int32 tri_id matching pixel_index "
                     "(pass the result of fragments(gbuffer))");
  if (!fragments.uv.defined() || fragments.uv.shape() != Shape{n, 2} || fragments.uv.dtype() != clip.dtype())
    throw ShapeError("interpolate: fragments.uv " +
                     (fragments.uv.defined() ? fragments.uv.describe() : std::string("undefined")) +
                     " must be [" + std::to_string(n) + ", 2] of clip's dtype " + dtype_name(clip.dtype()));
  Tensor out = Tensor::empty({n, c}, attributes.dtype());
  const bool perspective = options.perspective;
  dispatch_float(attributes.dtype(), "interpolate", [&](auto tag) {
    using T = decltype(tag);
    raster::interpolate_fragments_forward(attributes.data<T>(), attributes.size(0), c, clip.data<T>(),
                                          triangles.data<std::int32_t>(), triangles.size(0),
                                          fragments.tri_id.data<std::int32_t>(), fragments.uv.data<T>(),
                                          fragments.pixel_index.data<std::int32_t>(), n, fragments.width,
                                          fragments.height, perspective, out.data<T>());
  });
  const Tensor& uv = fragments.uv;
  if (should_record({attributes, clip, uv})) {
    // Same adjoint as the image form, over the fragments' rows.
    record("interpolate_fragments", {attributes, clip, uv}, {&out},
           [attributes, clip, triangles, tri_id = fragments.tri_id, pixel_index = fragments.pixel_index,
            width = fragments.width, height = fragments.height, uv = uv.detach(), perspective](AdjointContext& ctx) {
             Tensor g_attr = ctx.needs_grad(0) ? Tensor::zeros(attributes.shape(), attributes.dtype()) : Tensor();
             Tensor g_clip = ctx.needs_grad(1) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
             Tensor g_uv = ctx.needs_grad(2) ? Tensor::zeros(uv.shape(), uv.dtype()) : Tensor();
             dispatch_float(attributes.dtype(), "interpolate", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::interpolate_fragments_backward(
                   attributes.data<T>(), attributes.size(0), attributes.size(1), clip.data<T>(),
                   triangles.data<std::int32_t>(), triangles.size(0), tri_id.data<std::int32_t>(), uv.data<T>(),
                   pixel_index.data<std::int32_t>(), tri_id.size(0), width, height, perspective,
                   ctx.grad_output().data<T>(), ptr(g_attr), ptr(g_clip), ptr(g_uv));
             });
             if (g_attr.defined()) ctx.accumulate(0, g_attr);
             if (g_clip.defined()) ctx.accumulate(1, g_clip);
             if (g_uv.defined()) ctx.accumulate(2, g_uv);
           });
  }
  return out;
}

InterpolatedWithDerivatives interpolate_with_derivatives(const Tensor& attributes, const Tensor& clip,
                                                         const GBuffer& gbuffer, const Tensor& triangles,
                                                         const InterpolateOptions& options) {
  InterpolatedWithDerivatives r;
  // Validates the arguments and records the values as usual.
  r.values = interpolate(attributes, clip, gbuffer, triangles, options);
  const std::int64_t h = gbuffer.tri_id.size(0), w = gbuffer.tri_id.size(1), c = attributes.size(1);
  r.d_dx = Tensor::empty({h, w, c}, attributes.dtype());
  r.d_dy = Tensor::empty({h, w, c}, attributes.dtype());
  dispatch_float(attributes.dtype(), "interpolate", [&](auto tag) {
    using T = decltype(tag);
    raster::interpolate_derivatives(attributes.data<T>(), attributes.size(0), c, clip.data<T>(),
                                    triangles.data<std::int32_t>(), triangles.size(0),
                                    gbuffer.tri_id.data<std::int32_t>(), gbuffer.uv.data<T>(), int(w), int(h),
                                    options.perspective, r.d_dx.data<T>(), r.d_dy.data<T>());
  });
  return r;
}

}  // namespace gr
