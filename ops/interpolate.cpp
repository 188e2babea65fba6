// Tape op over raster::interpolate_forward / interpolate_backward, image and
// fragment forms: both validate here, build one raster::InterpolateParams and
// record one adjoint.
#include "ops/interpolate.h"

#include "autodiff/tape.h"
#include "ops/check.h"
#include "raster/interpolate.h"
#include "raster/triangle_groups.h"

namespace gr {
namespace {

const char* const kOp = "interpolate";

// Checks shared by the image and fragment forms.
void check_attributes(const Tensor& attributes, const Tensor& clip, const Tensor& triangles) {
  detail::check_clip_and_triangles(clip, triangles, kOp);
  detail::check_float(attributes, kOp, "attributes");
  if (attributes.rank() != 2 || attributes.size(0) != clip.size(0))
    throw ShapeError("interpolate: argument 'attributes' must have shape [N, C] with N = " +
                     std::to_string(clip.size(0)) + " vertices (rows of clip), got " + attributes.describe());
  detail::check_same_dtype(attributes, clip, kOp, "attributes", "clip");
  // NaN/Inf attributes would silently spread over every pixel of their triangles.
  detail::check_finite(attributes, kOp, "attributes");
}

void check_gbuffer(const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles) {
  if (!gbuffer.tri_id.defined() || gbuffer.tri_id.dtype() != DType::Int32 || gbuffer.tri_id.rank() != 2)
    throw ShapeError("interpolate: argument 'gbuffer' has no [H, W] int32 tri_id (pass the result of rasterize)");
  const std::int64_t h = gbuffer.tri_id.size(0), w = gbuffer.tri_id.size(1);
  detail::check_image_size(w, h, kOp);
  if (gbuffer.uv.shape() != Shape{h, w, 2} || gbuffer.uv.dtype() != clip.dtype())
    throw ShapeError("interpolate: gbuffer.uv " + gbuffer.uv.describe() + " does not match tri_id " +
                     gbuffer.tri_id.describe() + " and clip dtype");
  detail::check_tri_ids(gbuffer.tri_id, triangles.size(0), kOp);
  detail::check_gbuffer_source(gbuffer, clip, triangles, kOp);
}

// Fragments are covered pixels: every tri_id in [1, M], every pixel_index in [0, W*H).
void check_fragments(const Fragments& fragments, const Tensor& clip, const Tensor& triangles) {
  detail::check_dtype(fragments.pixel_index, DType::Int32, kOp, "fragments.pixel_index");
  const std::int64_t n = fragments.count();
  detail::check_shape(fragments.pixel_index, {n}, kOp, "fragments.pixel_index");
  if (!fragments.tri_id.defined() || fragments.tri_id.dtype() != DType::Int32 || fragments.tri_id.shape() != Shape{n})
    throw ShapeError("interpolate: argument 'fragments' has no [F] int32 tri_id matching pixel_index "
                     "(pass the result of fragments(gbuffer))");
  if (!fragments.uv.defined() || fragments.uv.shape() != Shape{n, 2} || fragments.uv.dtype() != clip.dtype())
    throw ShapeError("interpolate: fragments.uv " +
                     (fragments.uv.defined() ? fragments.uv.describe() : std::string("undefined")) +
                     " must be [" + std::to_string(n) + ", 2] of clip's dtype " + dtype_name(clip.dtype()));
  detail::check_image_size(fragments.width, fragments.height, kOp);
  const std::int64_t m = triangles.size(0), pixels = std::int64_t(fragments.width) * fragments.height;
  const std::int32_t* tri_id = fragments.tri_id.data<std::int32_t>();
  const std::int32_t* pixel_index = fragments.pixel_index.data<std::int32_t>();
  for (std::int64_t f = 0; f < n; ++f) {
    if (tri_id[f] < 1 || tri_id[f] > m)
      throw IndexError("interpolate: fragment " + std::to_string(f) + " has tri_id " + std::to_string(tri_id[f]) +
                       ", outside [1, " + std::to_string(m) + "] (fragments must be covered pixels)");
    if (pixel_index[f] < 0 || pixel_index[f] >= pixels)
      throw IndexError("interpolate: fragment " + std::to_string(f) + " has pixel_index " +
                       std::to_string(pixel_index[f]) + ", outside [0, " + std::to_string(pixels) + ")");
  }
}

// The kernels' view of validated tensors (the form follows from pixel_index).
template <class T>
raster::InterpolateParams<T> params(const Tensor& attributes, const Tensor& clip, const Tensor& triangles,
                                    const Tensor& tri_id, const Tensor& uv, int width, int height,
                                    const Tensor& pixel_index, bool perspective) {
  raster::InterpolateParams<T> p;
  p.attr = attributes.data<T>();
  p.num_vertices = attributes.size(0);
  p.channels = attributes.size(1);
  p.clip = clip.data<T>();
  p.tris = triangles.data<std::int32_t>();
  p.num_tris = triangles.size(0);
  p.tri_id = tri_id.data<std::int32_t>();
  p.uv = uv.data<T>();
  p.width = width;
  p.height = height;
  if (pixel_index.defined()) {
    p.pixel_index = pixel_index.data<std::int32_t>();
    p.count = pixel_index.size(0);
  }
  p.perspective = perspective;
  return p;
}

// Runs the forward into a new [items..., C] tensor of `out_shape` and records
// the adjoint to attributes, clip and uv. pixel_index undefined: image form.
Tensor interpolate_items(const Tensor& attributes, const Tensor& clip, const Tensor& triangles,
                         const Tensor& tri_id, const Tensor& uv, int width, int height, const Tensor& pixel_index,
                         bool perspective, const Tensor& background, const Shape& out_shape,
                         const std::shared_ptr<raster::TriangleGroups>& groups) {
  Tensor out = Tensor::empty(out_shape, attributes.dtype());
  dispatch_float(attributes.dtype(), kOp, [&](auto tag) {
    using T = decltype(tag);
    raster::InterpolateParams<T> p =
        params<T>(attributes, clip, triangles, tri_id, uv, width, height, pixel_index, perspective);
    p.background = background.defined() ? background.data<T>() : nullptr;
    raster::interpolate_forward(p, out.data<T>());
  });
  if (should_record({attributes, clip, uv})) {
    // The index tensors get no gradient; listed so that backward() refuses them written in place.
    record(pixel_index.defined() ? "interpolate_fragments" : "interpolate",
           {attributes, clip, uv, triangles, tri_id, pixel_index}, {&out},
           [attributes, clip, triangles, tri_id, uv = uv.detach(), width, height, pixel_index,
            perspective, groups](AdjointContext& ctx) {
             // The kernel adds (+=) into the gradients summed so far.
             Tensor g_attr = ctx.accumulation_buffer(0);
             Tensor g_clip = ctx.accumulation_buffer(1);
             Tensor g_uv = ctx.accumulation_buffer(2);
             dispatch_float(attributes.dtype(), kOp, [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::InterpolateParams<T> p =
                   params<T>(attributes, clip, triangles, tri_id, uv, width, height, pixel_index, perspective);
               p.groups = groups.get();
               raster::interpolate_backward(p, ctx.grad_output().data<T>(), {ptr(g_attr), ptr(g_clip), ptr(g_uv)});
             });
           });
  }
  return out;
}

}  // namespace

Tensor interpolate(const Tensor& attributes, const Tensor& clip, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options) {
  check_attributes(attributes, clip, triangles);
  check_gbuffer(gbuffer, clip, triangles);
  const std::int64_t h = gbuffer.tri_id.size(0), w = gbuffer.tri_id.size(1), c = attributes.size(1);
  const Tensor& background = options.background;
  if (background.defined()) {
    detail::check_float(background, kOp, "background");
    if (background.numel() != c || background.dtype() != attributes.dtype())
      throw ShapeError("interpolate: background " + background.describe() + " must hold C = " + std::to_string(c) +
                       " values of the attributes' dtype");
    // A NaN/Inf background would fill every uncovered pixel with it.
    detail::check_finite(background, kOp, "background");
  }
  return interpolate_items(attributes, clip, triangles, gbuffer.tri_id, gbuffer.uv, int(w), int(h), Tensor(),
                           options.perspective, background, {h, w, c}, gbuffer.groups);
}

Tensor interpolate(const Tensor& attributes, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options) {
  if (!gbuffer.clip.defined())
    throw ValueError("interpolate: argument 'gbuffer' does not record the clip positions it was rasterized from "
                     "(pass the result of rasterize, or call interpolate(attributes, clip, gbuffer, triangles))");
  return interpolate(attributes, gbuffer.clip, gbuffer, triangles, options);
}

Tensor interpolate(const Tensor& attributes, const Tensor& clip, const Fragments& fragments, const Tensor& triangles,
                   const InterpolateOptions& options) {
  check_attributes(attributes, clip, triangles);
  if (options.background.defined())
    throw ValueError("interpolate: options.background has no meaning for fragments (every fragment is covered); "
                     "pass it to to_image");
  check_fragments(fragments, clip, triangles);
  return interpolate_items(attributes, clip, triangles, fragments.tri_id, fragments.uv, fragments.width,
                           fragments.height, fragments.pixel_index, options.perspective, Tensor(),
                           {fragments.count(), attributes.size(1)}, fragments.groups);
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
  dispatch_float(attributes.dtype(), kOp, [&](auto tag) {
    using T = decltype(tag);
    raster::interpolate_derivatives(params<T>(attributes, clip, triangles, gbuffer.tri_id, gbuffer.uv, int(w), int(h),
                                              Tensor(), options.perspective),
                                    r.d_dx.data<T>(), r.d_dy.data<T>());
  });
  return r;
}

}  // namespace gr
