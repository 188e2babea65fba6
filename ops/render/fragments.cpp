// Fragment compaction, gather_fragments and to_image: forward and adjoint side
// by side. Kernels in raster/fragments.h.
#include "ops/render/fragments.h"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "raster/fragments.h"

namespace gr {
namespace {

// Throws unless `fr` looks like the result of fragments(): int32 [F] pixel
// indices, strictly ascending inside the image, and int32 [F] triangle ids.
void check_fragments(const Fragments& fr, const std::string& op) {
  if (fr.width < 1 || fr.height < 1)
    throw ValueError(op + ": argument 'fragments' has size " + std::to_string(fr.width) + " x " +
                     std::to_string(fr.height) + " (pass the result of fragments(gbuffer))");
  if (!fr.pixel_index.defined() || fr.pixel_index.dtype() != DType::Int32 || fr.pixel_index.rank() != 1)
    throw ShapeError(op + ": argument 'fragments' has no [F] int32 pixel_index (pass the result of fragments(gbuffer))");
  const std::int64_t n = fr.pixel_index.size(0);
  if (!fr.tri_id.defined() || fr.tri_id.dtype() != DType::Int32 || fr.tri_id.shape() != Shape{n})
    throw ShapeError(op + ": fragments.tri_id must be int32 [" + std::to_string(n) + "], got " +
                     (fr.tri_id.defined() ? fr.tri_id.describe() : std::string("undefined")));
  const std::int64_t pixels = static_cast<std::int64_t>(fr.width) * fr.height;
  const std::int32_t* idx = fr.pixel_index.data<std::int32_t>();
  for (std::int64_t f = 0; f < n; ++f)
    if (idx[f] < 0 || idx[f] >= pixels || (f > 0 && idx[f] <= idx[f - 1]))
      throw IndexError(op + ": fragments.pixel_index element " + std::to_string(f) + " is " +
                       std::to_string(idx[f]) + "; indices must be strictly ascending in [0, " +
                       std::to_string(pixels) + ")");
}

// Calls f(T{}) for float32/float64, naming the argument otherwise.
template <class F>
void dispatch(const Tensor& t, const std::string& what, F&& f) {
  dispatch_float(t.dtype(), what, std::forward<F>(f));
}

}  // namespace

Fragments fragments(const GBuffer& gbuffer) {
  const Tensor& id = gbuffer.tri_id;
  if (!id.defined() || id.dtype() != DType::Int32 || id.rank() != 2)
    throw ShapeError("fragments: argument 'gbuffer' has no [H, W] int32 tri_id (pass the result of rasterize)");
  const std::int64_t h = id.size(0), w = id.size(1);
  if (!gbuffer.uv.defined() || gbuffer.uv.shape() != Shape{h, w, 2})
    throw ShapeError("fragments: gbuffer.uv " + (gbuffer.uv.defined() ? gbuffer.uv.describe() : std::string("undefined")) +
                     " does not match tri_id " + id.describe());
  detail::check_float(gbuffer.uv, "fragments", "gbuffer.uv");
  Fragments fr;
  fr.width = static_cast<int>(w);
  fr.height = static_cast<int>(h);
  guard_allocation("fragments", [&] {
    const raster::FragmentPlan plan = raster::plan_fragments(id.data<std::int32_t>(), h * w);
    fr.pixel_index = Tensor::empty({plan.count()}, DType::Int32);
    fr.tri_id = Tensor::empty({plan.count()}, DType::Int32);
    raster::compact_fragments(id.data<std::int32_t>(), h * w, plan, fr.pixel_index.data<std::int32_t>(),
                              fr.tri_id.data<std::int32_t>());
  });
  fr.uv = gather_fragments(gbuffer.uv, fr);
  return fr;
}

Tensor gather_fragments(const Tensor& image, const Fragments& fr) {
  check_fragments(fr, "gather_fragments");
  detail::check_float(image, "gather_fragments", "image");
  if (image.rank() != 3 || image.size(0) != fr.height || image.size(1) != fr.width)
    throw ShapeError("gather_fragments: argument 'image' must have shape [" + std::to_string(fr.height) + ", " +
                     std::to_string(fr.width) + ", C] (the fragments' image size), got " + image.describe());
  const std::int64_t n = fr.count(), c = image.size(2);
  Tensor out = Tensor::empty({n, c}, image.dtype());
  dispatch(image, "gather_fragments: argument 'image'", [&](auto tag) {
    using T = decltype(tag);
    raster::gather_fragment_rows(image.data<T>(), fr.pixel_index.data<std::int32_t>(), n, c, out.data<T>());
  });
  if (should_record({image})) {
    // pixel_index: no gradient, checked for in-place writes (autodiff/tape.h).
    record("gather_fragments", {image, fr.pixel_index}, {&out}, [index = fr.pixel_index,
                                                                 shape = image.shape()](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/dimage = g's rows at the fragments' pixels, zero elsewhere.
      Tensor grad = Tensor::zeros(shape, g.dtype());
      dispatch(g, "gather_fragments", [&](auto tag) {
        using T = decltype(tag);
        raster::scatter_fragment_rows(g.data<T>(), index.data<std::int32_t>(), index.size(0), shape[2], grad.data<T>());
      });
      ctx.accumulate(0, grad);
    });
  }
  return out;
}

Tensor to_image(const Tensor& values, const Fragments& fr, const Tensor& background) {
  check_fragments(fr, "to_image");
  detail::check_float(values, "to_image", "values");
  const std::int64_t n = fr.count(), h = fr.height, w = fr.width;
  if (values.rank() != 2 || values.size(0) != n)
    throw ShapeError("to_image: argument 'values' must have shape [F, C] with F = " + std::to_string(n) +
                     " fragments, got " + values.describe());
  const std::int64_t c = values.size(1);
  const Shape image_shape{h, w, c};
  // Background: none (zeros), one value per channel, or a whole image.
  const bool per_pixel = background.defined() && background.shape() == image_shape;
  if (background.defined()) {
    detail::check_float(background, "to_image", "background");
    detail::check_same_dtype(background, values, "to_image", "background", "values");
    if (!per_pixel && (background.rank() != 1 || background.size(0) != c))
      throw ShapeError("to_image: argument 'background' " + background.describe() + " must be [" + std::to_string(c) +
                       "] or " + image_shape.str());
  }
  Tensor out = Tensor::empty(image_shape, values.dtype());
  dispatch(values, "to_image: argument 'values'", [&](auto tag) {
    using T = decltype(tag);
    T* o = out.data<T>();
    if (per_pixel) {
      const T* b = background.data<T>();
      std::copy(b, b + h * w * c, o);
    } else if (background.defined()) {
      raster::fill_pixels(background.data<T>(), h * w, c, o);
    } else {
      const std::vector<T> zero(static_cast<std::size_t>(c), T(0));
      raster::fill_pixels(zero.data(), h * w, c, o);
    }
    raster::scatter_fragment_rows(values.data<T>(), fr.pixel_index.data<std::int32_t>(), n, c, o);
  });
  if (should_record({values, background})) {
    // pixel_index: no gradient, checked for in-place writes (autodiff/tape.h).
    record("to_image", {values, background, fr.pixel_index}, {&out},
           [index = fr.pixel_index, bg_shape = background.defined() ? background.shape() : Shape{}, per_pixel,
            h, w, c](AdjointContext& ctx) {
             const Tensor& g = ctx.grad_output();
             if (!g.defined()) return;
             const std::int64_t n = index.size(0);
             const std::int32_t* idx = index.data<std::int32_t>();
             dispatch(g, "to_image", [&](auto tag) {
               using T = decltype(tag);
               if (ctx.needs_grad(0)) {
                 // dL/dvalues[f] = g[pixel_index[f]].
                 Tensor gv = Tensor::empty({n, c}, g.dtype());
                 raster::gather_fragment_rows(g.data<T>(), idx, n, c, gv.data<T>());
                 ctx.accumulate(0, gv);
               }
               if (ctx.needs_grad(1)) {
                 Tensor gb = Tensor::empty(bg_shape, g.dtype());
                 if (per_pixel) {
                   // dL/dbackground = g with the covered pixels zeroed.
                   std::copy(g.data<T>(), g.data<T>() + h * w * c, gb.data<T>());
                   raster::zero_fragment_rows(idx, n, c, gb.data<T>());
                 } else {
                   // dL/dbackground[c] = sum of g[p, c] over uncovered pixels p.
                   raster::sum_uncovered(g.data<T>(), h * w, c, idx, n, gb.data<T>());
                 }
                 ctx.accumulate(1, gb);
               }
             });
           });
  }
  return out;
}

}  // namespace gr
