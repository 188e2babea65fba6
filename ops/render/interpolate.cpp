// Tape op over raster::barycentric_interpolate_forward / _backward, image and
// fragment forms: both validate here, give the kernels the items' uv and ids
// (BarycentricInterpolateParams' planar form) and record one adjoint. The
// image form runs on the G-buffer's backend when it has one (float32), on the
// device's copy of the G-buffer while it matches the host's.
#include "ops/render/interpolate.h"

#include <algorithm>
#include <type_traits>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/render/resident_gbuffer.h"
#include "raster/barycentric_interpolate.h"
#include "raster/detail/triangle_groups.h"

namespace gr {
namespace {

const char* const kOp = "interpolate";

// clip: the rasterized clip positions (undefined if not known), whose rows
// the attributes must match.
void check_attributes(const Tensor& attributes, const Tensor& triangles, const Tensor& clip) {
  detail::check_float(attributes, kOp, "attributes");
  if (clip.defined()) {
    if (attributes.rank() != 2 || attributes.size(0) != clip.size(0))
      throw ShapeError("interpolate: argument 'attributes' must have shape [N, C] with N = " +
                       std::to_string(clip.size(0)) + " vertices (rows of the rasterized clip), got " +
                       attributes.describe());
    detail::check_same_dtype(attributes, clip, kOp, "attributes", "gbuffer.clip");
  } else if (attributes.rank() != 2) {
    throw ShapeError("interpolate: argument 'attributes' must have shape [N, C], got " + attributes.describe());
  }
  detail::check_triangles(triangles, attributes.size(0), kOp);
  // NaN/Inf attributes would silently spread over every pixel of their triangles.
  detail::check_finite(attributes, kOp, "attributes");
}

// The items' shape with a channel axis.
Shape with_channels(const Shape& items, std::int64_t channels) {
  std::vector<std::int64_t> d = items.dims();
  d.push_back(channels);
  return Shape(d);
}

// uv [items..., 2] (and db [items..., 4]) of the attributes' dtype.
void check_item_tensor(const Tensor& t, const Shape& items, std::int64_t channels, const Tensor& attributes,
                       const char* name) {
  const Shape want = with_channels(items, channels);
  if (!t.defined() || t.shape() != want || t.dtype() != attributes.dtype())
    throw ShapeError(std::string("interpolate: ") + name + " " + (t.defined() ? t.describe() : std::string("undefined")) +
                     " must be " + Tensor::empty(want, attributes.dtype()).describe() +
                     " (the attributes' dtype; pass the result of rasterize)");
}

void check_gbuffer(const GBuffer& gbuffer, const Tensor& attributes, const Tensor& triangles, bool derivatives) {
  if (!gbuffer.tri_id.defined() || gbuffer.tri_id.dtype() != DType::Int32 || gbuffer.tri_id.rank() != 2)
    throw ShapeError("interpolate: argument 'gbuffer' has no [H, W] int32 tri_id (pass the result of rasterize)");
  const std::int64_t h = gbuffer.tri_id.size(0), w = gbuffer.tri_id.size(1);
  detail::check_image_size(w, h, kOp);
  check_item_tensor(gbuffer.uv, {h, w}, 2, attributes, "gbuffer.uv");
  if (derivatives) {
    if (!gbuffer.db.defined())
      throw ValueError("interpolate: the derivatives need gbuffer.db (rasterize with options.derivatives = true)");
    check_item_tensor(gbuffer.db, {h, w}, 4, attributes, "gbuffer.db");
  }
  detail::check_tri_ids(gbuffer.tri_id, triangles.size(0), kOp);
  if (gbuffer.clip.defined()) detail::check_gbuffer_source(gbuffer, gbuffer.clip, triangles, kOp);
}

// Fragments are covered pixels: every tri_id in [1, M], every pixel_index in [0, W*H).
void check_fragments(const Fragments& fragments, const Tensor& attributes, const Tensor& triangles) {
  detail::check_dtype(fragments.pixel_index, DType::Int32, kOp, "fragments.pixel_index");
  const std::int64_t n = fragments.count();
  detail::check_shape(fragments.pixel_index, {n}, kOp, "fragments.pixel_index");
  if (!fragments.tri_id.defined() || fragments.tri_id.dtype() != DType::Int32 || fragments.tri_id.shape() != Shape{n})
    throw ShapeError("interpolate: argument 'fragments' has no [F] int32 tri_id matching pixel_index "
                     "(pass the result of fragments(gbuffer))");
  check_item_tensor(fragments.uv, {n}, 2, attributes, "fragments.uv");
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

void check_background(const Tensor& background, const Tensor& attributes) {
  if (!background.defined()) return;
  detail::check_float(background, kOp, "background");
  const std::int64_t c = attributes.size(1);
  if (background.numel() != c || background.dtype() != attributes.dtype())
    throw ShapeError("interpolate: background " + background.describe() + " must hold C = " + std::to_string(c) +
                     " values of the attributes' dtype");
  // A NaN/Inf background would fill every uncovered pixel with it.
  detail::check_finite(background, kOp, "background");
}

// The channels to differentiate: options.diff_attrs, or all.
std::vector<std::int32_t> diff_channels(const InterpolateOptions& options, std::int64_t channels) {
  std::vector<std::int32_t> diff = options.diff_attrs;
  if (diff.empty())
    for (std::int64_t c = 0; c < channels; ++c) diff.push_back(static_cast<std::int32_t>(c));
  for (std::int32_t c : diff)
    if (c < 0 || c >= channels)
      throw IndexError("interpolate: options.diff_attrs holds channel " + std::to_string(c) + ", outside [0, " +
                       std::to_string(channels) + ")");
  return diff;
}

// What one call interpolates: items (pixels or fragments) with their tri_id,
// uv and, for the derivatives, db; out_shape = the items' shape.
struct Items {
  Tensor tri_id, uv, db, pixel_index;
  Shape shape;
  std::shared_ptr<raster::TriangleGroups> groups;  // the G-buffer's (or null)
  // The G-buffer's backend (image form only; null: the CPU) and image size.
  std::shared_ptr<const raster::RasterBackend> backend;
  int width = 0, height = 0;
  // The G-buffer, when its backend keeps a copy on the device (else null).
  std::shared_ptr<const GBuffer> resident_source;
  std::int64_t count() const { return tri_id.numel(); }
};

// The image form's items: the G-buffer's pixels, on its backend.
Items gbuffer_items(const GBuffer& gbuffer, bool derivatives) {
  return {gbuffer.tri_id, gbuffer.uv, derivatives ? gbuffer.db : Tensor(), Tensor(), gbuffer.tri_id.shape(),
          gbuffer.groups, gbuffer.backend, gbuffer.width(), gbuffer.height(),
          gbuffer.resident ? std::make_shared<const GBuffer>(gbuffer) : nullptr};
}

// The device's copy of the items' G-buffer, while it matches the host's (else null).
const raster::DeviceGBuffer* resident(const std::shared_ptr<const GBuffer>& source) {
  return source ? detail::resident_of(*source) : nullptr;
}

// Runs the forward and records the adjoint to attributes, uv and db. diff
// null: values only; else [values, d_dx, d_dy].
std::vector<Tensor> interpolate_items(const Tensor& attributes, const Tensor& triangles, const Items& items,
                                      const std::vector<std::int32_t>* diff, const Tensor& background) {
  const std::int64_t n = items.count(), C = attributes.size(1);
  const std::int64_t K = diff ? static_cast<std::int64_t>(diff->size()) : 0;
  const auto diff_list = std::make_shared<std::vector<std::int32_t>>(diff ? *diff : std::vector<std::int32_t>());
  auto params = [=](auto tag) {
    using T = decltype(tag);
    raster::BarycentricInterpolateParams<T> p;
    p.attr = attributes.data<T>();
    p.num_vertices = attributes.size(0);
    p.channels = C;
    p.tris = triangles.data<std::int32_t>();
    p.num_tris = triangles.size(0);
    p.rast = items.uv.data<T>();  // the GBuffer's planes: uv and int32 ids
    p.rast_stride = 2;
    p.tri_id = items.tri_id.data<std::int32_t>();
    p.pixels = n;
    p.groups = items.groups.get();
    if (K > 0) {
      p.rast_db = items.db.data<T>();
      p.diff = diff_list->data();
      p.num_diff = K;
    }
    return p;
  };
  std::vector<Tensor> out = {Tensor::empty(with_channels(items.shape, C), attributes.dtype())};
  if (diff) {
    out.push_back(Tensor::empty(with_channels(items.shape, K), attributes.dtype()));
    out.push_back(Tensor::empty(with_channels(items.shape, K), attributes.dtype()));
  }
  const Tensor uv = items.uv, db = K > 0 ? items.db : Tensor();
  const bool rec = should_record({attributes, uv, db});
  std::shared_ptr<const raster::DeviceForward> kept;  // on the backend, for the adjoint
  dispatch_float(attributes.dtype(), kOp, [&](auto tag) {
    using T = decltype(tag);
    Tensor da = K > 0 ? Tensor::empty({n * 2 * K}, attributes.dtype()) : Tensor();
    bool on_backend = false;
    if constexpr (std::is_same_v<T, float>)
      if (items.backend) {
        T* o = out[0].data<T>();
        T* d = K > 0 ? da.data<T>() : nullptr;
        on_backend = items.backend->interpolate_forward(resident(items.resident_source), params(tag), items.width,
                                                        items.height, o, d, rec ? &kept : nullptr);
      }
    if (!on_backend)
      raster::barycentric_interpolate_forward(params(tag), out[0].data<T>(), K > 0 ? da.data<T>() : nullptr);
    const std::int32_t* id = items.tri_id.data<std::int32_t>();
    if (background.defined()) {
      T* o = out[0].data<T>();
      const T* bg = background.data<T>();
      parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t q = lo; q < hi; ++q)
          if (id[q] == 0) std::copy(bg, bg + C, o + q * C);
      });
    }
    if (K > 0) {
      const T* d = da.data<T>();
      T *dx = out[1].data<T>(), *dy = out[2].data<T>();
      parallel_for(0, n, kElementwiseGrain / (2 * K) + 1, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t q = lo; q < hi; ++q)
          for (std::int64_t j = 0; j < K; ++j) {
            dx[q * K + j] = d[q * 2 * K + 2 * j];
            dy[q * K + j] = d[q * 2 * K + 2 * j + 1];
          }
      });
    }
  });
  if (!rec) return out;
  std::vector<Tensor*> outputs;
  for (Tensor& t : out) outputs.push_back(&t);
  // The index tensors get no gradient; listed so that backward() refuses them written in place.
  record(items.pixel_index.defined() ? "interpolate_fragments" : "interpolate",
         {attributes, uv, db, triangles, items.tri_id, items.pixel_index}, outputs,
         [params, n, C, K, dtype = attributes.dtype(), backend = items.backend, w = items.width,
          h = items.height, source = items.resident_source, kept](AdjointContext& ctx) {
           // The kernel adds (+=) into the gradients summed so far.
           Tensor g_attr = ctx.accumulation_buffer(0);
           Tensor g_uv = ctx.accumulation_buffer(1);
           Tensor g_db = K > 0 ? ctx.accumulation_buffer(2) : Tensor();
           const Tensor& g_out = ctx.grad_output(0);
           dispatch_float(dtype, kOp, [&](auto tag) {
             using T = decltype(tag);
             const raster::BarycentricInterpolateParams<T> p = params(tag);
             const Tensor go = g_out.defined() ? g_out : Tensor::zeros({n * C}, dtype);
             Tensor gda;
             if (K > 0) {
               const Tensor& gx = ctx.grad_output(1);
               const Tensor& gy = ctx.grad_output(2);
               gda = Tensor::zeros({n * 2 * K}, dtype);
               T* d = gda.data<T>();
               parallel_for(0, n, kElementwiseGrain / (2 * K) + 1, [&](std::int64_t lo, std::int64_t hi) {
                 for (std::int64_t q = lo; q < hi; ++q)
                   for (std::int64_t j = 0; j < K; ++j) {
                     if (gx.defined()) d[q * 2 * K + 2 * j] = gx.data<T>()[q * K + j];
                     if (gy.defined()) d[q * 2 * K + 2 * j + 1] = gy.data<T>()[q * K + j];
                   }
               });
             }
             raster::BarycentricInterpolateGrads<T> grads;
             grads.attr = g_attr.defined() ? g_attr.data<T>() : nullptr;
             grads.rast = g_uv.defined() ? g_uv.data<T>() : nullptr;
             grads.rast_db = g_db.defined() ? g_db.data<T>() : nullptr;
             if constexpr (std::is_same_v<T, float>)
               if (backend) {
                 const T* gd = K > 0 ? gda.data<T>() : nullptr;
                 if (backend->interpolate_backward(resident(source), p, w, h, go.data<T>(), gd, grads, kept.get()))
                   return;
               }
             raster::barycentric_interpolate_backward(p, go.data<T>(), K > 0 ? gda.data<T>() : nullptr, grads);
           });
         });
  return out;
}

}  // namespace

Tensor interpolate(const Tensor& attributes, const GBuffer& gbuffer, const Tensor& triangles,
                   const InterpolateOptions& options) {
  check_attributes(attributes, triangles, gbuffer.clip);
  check_gbuffer(gbuffer, attributes, triangles, false);
  check_background(options.background, attributes);
  return interpolate_items(attributes, triangles, gbuffer_items(gbuffer, false), nullptr, options.background)[0];
}

Tensor interpolate(const Tensor& attributes, const Fragments& fragments, const Tensor& triangles,
                   const InterpolateOptions& options) {
  check_attributes(attributes, triangles, Tensor());
  if (options.background.defined())
    throw ValueError("interpolate: options.background has no meaning for fragments (every fragment is covered); "
                     "pass it to to_image");
  check_fragments(fragments, attributes, triangles);
  const Items items{fragments.tri_id, fragments.uv, Tensor(), fragments.pixel_index, {fragments.count()},
                    nullptr, nullptr, 0, 0, nullptr};  // no backend: the fragment form runs on the CPU
  return interpolate_items(attributes, triangles, items, nullptr, Tensor())[0];
}

InterpolatedWithDerivatives interpolate_with_derivatives(const Tensor& attributes, const GBuffer& gbuffer,
                                                         const Tensor& triangles, const InterpolateOptions& options) {
  check_attributes(attributes, triangles, gbuffer.clip);
  check_gbuffer(gbuffer, attributes, triangles, true);
  check_background(options.background, attributes);
  const std::vector<std::int32_t> diff = diff_channels(options, attributes.size(1));
  std::vector<Tensor> out =
      interpolate_items(attributes, triangles, gbuffer_items(gbuffer, true), &diff, options.background);
  return {out[0], out[1], out[2]};
}

}  // namespace gr
