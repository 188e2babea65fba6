// Batched rasterize, interpolate and antialias: the single-image kernels on
// slices of [B, ...] tensors, images in parallel, one tape node per call.
#include "ops/render/batch.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/render/resident_gbuffer.h"
#include "ops/render/topology_cache.h"
#include "raster/blended_pairs.h"
#include "raster/barycentric_interpolate.h"

namespace gr {
namespace {

using raster::for_each_image;

// An input with or without an image axis: image b's rows, and whether the
// images share it.
struct PerImage {
  const Tensor* t;
  bool shared;
  std::int64_t rows, cols;
  template <class T>
  const T* at(std::int64_t b) const {
    return t->data<T>() + (shared ? 0 : b * rows * cols);
  }
};

PerImage per_image(const Tensor& t, std::int64_t images, std::int64_t rows, const std::string& op, const char* name,
                   const char* shape) {
  detail::check_float(t, op, name);
  const bool shared = t.rank() == 2;
  if (!(shared || t.rank() == 3) || (!shared && t.size(0) != images) || t.size(t.rank() - 2) != rows)
    throw ShapeError(op + ": argument '" + name + "' must be " + shape + " with B = " + std::to_string(images) +
                     " images and N = " + std::to_string(rows) + ", got " + t.describe());
  return {&t, shared, rows, t.size(t.rank() - 1)};
}

// Gradient buffers of a PerImage input: slices of one tensor, or one buffer
// per image summed in image order at the end (a shared input,
// raster::sum_in_image_order).
struct GradOf {
  Tensor total;
  std::vector<Tensor> parts;
  GradOf(const PerImage& in, std::int64_t images) : total(Tensor::zeros(in.t->shape(), in.t->dtype())) {
    if (in.shared)
      for (std::int64_t b = 0; b < images; ++b) parts.push_back(Tensor::zeros(in.t->shape(), in.t->dtype()));
  }
  template <class T>
  T* at(const PerImage& in, std::int64_t b) {
    return in.shared ? parts[b].data<T>() : total.data<T>() + b * in.rows * in.cols;
  }
  template <class T>
  Tensor finish() {
    if (parts.empty()) return total;
    std::vector<const T*> from;
    for (const Tensor& part : parts) from.push_back(part.data<T>());
    raster::sum_in_image_order(from.data(), static_cast<std::int64_t>(from.size()), total.numel(), total.data<T>());
    return total;
  }
};

// Runs call(on, p) for image b on the backend: p (image b's
// interpolate parameters over all the triangles) as the device's copy of the
// image drew it, with that copy while `made` still matches it
// (detail::image_on_device). Returns call's answer (false: the CPU runs it).
template <class Call>
bool on_device(const std::shared_ptr<const raster::RasterBackend>& backend, const GBuffer* made, std::int64_t b,
               raster::BarycentricInterpolateParams<float> p, const Tensor& triangles, const Call& call) {
  if (!backend) return false;
  const detail::ImageOnDevice on = detail::image_on_device(made, b, triangles, p.tri_id, p.pixels, false);
  p.tris = on.tris;
  p.num_tris = on.num_tris;
  p.tri_id = on.ids();
  return call(on, p);
}

void check_batched_gbuffer(const GBuffer& g, std::int64_t images, const Tensor& clip, const Tensor& triangles,
                           const std::string& op) {
  if (!g.tri_id.defined() || g.tri_id.dtype() != DType::Int32 || g.tri_id.rank() != 3 || g.tri_id.size(0) != images)
    throw ShapeError(op + ": argument 'gbuffer' has no [B, H, W] int32 tri_id with B = " + std::to_string(images) +
                     " (pass the result of rasterize_batch or rasterize_ranges)");
  const std::int64_t h = g.tri_id.size(1), w = g.tri_id.size(2);
  detail::check_image_size(w, h, op);
  if (g.uv.shape() != Shape{images, h, w, 2} || g.uv.dtype() != clip.dtype() ||
      g.depth.shape() != Shape{images, h, w} || g.depth.dtype() != clip.dtype())
    throw ShapeError(op + ": gbuffer.uv " + g.uv.describe() + " or depth " + g.depth.describe() +
                     " does not match tri_id " + g.tri_id.describe() + " and the dtype of 'clip'");
  detail::check_tri_ids(g.tri_id, triangles.size(0), op);
  detail::check_gbuffer_source(g, clip, triangles, op);
}

}  // namespace

namespace detail {
namespace {

// rasterize_images on the backend: each image's whole G-buffer made there
// (RasterBackend::rasterize_gbuffer), in image order, downloaded into gb's
// slices and kept (gb.resident, one handle per image). False, gb's arrays
// partly written, when the backend makes no G-buffers. The images' calls are
// deferred (raster::DeferredCalls): the device runs one while the host
// prepares the next, and the arrays are read once all are written.
bool gbuffers_on_device(const Tensor& clip, const Tensor& triangles, const raster::ImageBatch& batch,
                        const RasterizeOptions& o, raster::DepthPeelState* peel, GBuffer& gb) {
  const std::int64_t P = std::int64_t(o.height) * o.width;
  const raster::RasterSettings settings{o.width, o.height, o.cull, o.front_to_back};
  std::vector<ResidentGBuffer::Image> images;
  raster::DeferredCalls deferred(o.backend.get());
  for (std::int64_t b = 0; b < batch.images; ++b) {
    const auto [first, count] = batch.range(b);
    raster::RasterParams<float> p{clip.data<float>() + batch.pos_offset(b), batch.vertices,
                                  triangles.data<std::int32_t>() + 3 * first, count, settings};
    if (peel) p.floor_id = peel->floor_id(b), p.floor_z = peel->floor_z(b);
    std::int32_t* id = gb.tri_id.data<std::int32_t>() + b * P;
    std::shared_ptr<const raster::DeviceGBuffer> kept = o.backend->rasterize_gbuffer(
        p, id, gb.uv.data<float>() + 2 * b * P, gb.depth.data<float>() + b * P,
        gb.db.defined() ? gb.db.data<float>() + 4 * b * P : nullptr, peel ? peel->key_z(b) : nullptr);
    if (!kept) return false;
    images.push_back({std::move(kept), first, count});
  }
  deferred.finish();
  for (std::int64_t b = 0; b < batch.images; ++b) {
    std::int32_t* id = gb.tri_id.data<std::int32_t>() + b * P;
    if (peel) peel->keep_ids(b, id);
    // Ids index the whole triangle list (the device's copy keeps the range's).
    const std::int64_t first = batch.range(b).first;
    if (first != 0)
      for (std::int64_t q = 0; q < P; ++q) id[q] += id[q] ? static_cast<std::int32_t>(first) : 0;
  }
  gb.resident = keep_resident(std::move(images), gb);
  return true;
}

}  // namespace

raster::ImageBatch check_instanced(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options,
                                   const std::string& op) {
  check_image_size(options.width, options.height, op);
  check_float(clip, op, "clip");
  if (clip.rank() != 3 || clip.size(0) < 1 || clip.size(2) != 4)
    throw ShapeError(op + ": argument 'clip' must have shape [B, N, 4] with B >= 1, got " + clip.describe());
  check_triangles(triangles, clip.size(1), op);
  check_finite(clip, op, "clip");
  return raster::ImageBatch::instanced_mode(clip.size(0), clip.size(1), triangles.size(0));
}

raster::ImageBatch check_ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                                const RasterizeOptions& options, const std::string& op) {
  check_rasterize_inputs(clip, triangles, options, op.c_str());
  check_dtype(ranges, DType::Int32, op, "ranges");
  if (ranges.rank() != 2 || ranges.size(0) < 1 || ranges.size(1) != 2)
    throw ShapeError(op + ": argument 'ranges' must have shape [B, 2] with B >= 1, got " + ranges.describe());
  std::vector<raster::ImageBatch::Range> r(static_cast<std::size_t>(ranges.size(0)));
  const std::int32_t* v = ranges.data<std::int32_t>();
  for (std::size_t b = 0; b < r.size(); ++b) r[b] = {v[2 * b], v[2 * b + 1]};
  return raster::ImageBatch::range_mode(std::move(r), clip.size(0), triangles.size(0), op.c_str(), "triangles");
}

GBuffer rasterize_images(const Tensor& clip, const Tensor& triangles, const raster::ImageBatch& batch,
                         const RasterizeOptions& o, raster::DepthPeelState* peel, const char* op) {
  const std::int64_t B = batch.images, h = o.height, w = o.width, P = h * w;
  const raster::RasterSettings settings{o.width, o.height, o.cull, o.front_to_back};
  GBuffer gb;
  gb.clip = clip;
  gb.triangles = triangles;
  gb.tri_id = Tensor::empty({B, h, w}, DType::Int32);
  gb.uv = Tensor::empty({B, h, w, 2}, clip.dtype());
  gb.depth = Tensor::empty({B, h, w}, clip.dtype());
  if (o.derivatives) gb.db = Tensor::empty({B, h, w, 4}, clip.dtype());
  gb.backend = o.backend;
  if (peel) peel->begin_layer(B, w, h);
  if (o.backend && clip.dtype() == DType::Float32 && gbuffers_on_device(clip, triangles, batch, o, peel, gb)) {
    if (peel) peel->end_layer();
    record_gbuffer_adjoint(gb, op);
    return gb;
  }
  std::vector<raster::RasterStats> stats(static_cast<std::size_t>(B));
  const std::int32_t* tris = triangles.data<std::int32_t>();
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    for_each_image(B, [&](std::int64_t b) {
      // The kernel numbers the image's triangles from 1 (its floor ids too).
      const auto [first, count] = batch.range(b);
      const raster::RasterParams<T> p{clip.data<T>() + batch.pos_offset(b), batch.vertices, tris + 3 * first, count,
                                      settings};
      std::int32_t* id = gb.tri_id.data<std::int32_t>() + b * P;
      // The coverage only (finish_gbuffer writes uv and depth).
      T* const no_values = nullptr;
      if (peel)
        peel->rasterize_image(p, b, id, no_values, no_values, &stats[b], o.backend.get());
      else
        raster::rasterize_forward_on(o.backend.get(), p, id, no_values, no_values, &stats[b]);
      // Ids index the whole triangle list.
      if (first != 0)
        for (std::int64_t q = 0; q < P; ++q) id[q] += id[q] ? static_cast<std::int32_t>(first) : 0;
    });
  });
  if (peel) peel->end_layer();
  for (const raster::RasterStats& s : stats) {
    gb.stats.triangles_in += s.triangles_in;
    gb.stats.culled_outside += s.culled_outside;
    gb.stats.culled_zero_area += s.culled_zero_area;
    gb.stats.culled_face += s.culled_face;
    gb.stats.culled_no_pixel += s.culled_no_pixel;
    gb.stats.rasterized += s.rasterized;
    gb.stats.clipped_near += s.clipped_near;
  }
  finish_gbuffer(gb, op);
  return gb;
}

}  // namespace detail

GBuffer rasterize_batch(const Tensor& clip, const Tensor& triangles, const RasterizeOptions& options) {
  const char* op = "rasterize_batch";
  return detail::rasterize_images(clip, triangles, detail::check_instanced(clip, triangles, options, op), options,
                                  nullptr, op);
}

GBuffer rasterize_ranges(const Tensor& clip, const Tensor& triangles, const Tensor& ranges,
                         const RasterizeOptions& options) {
  const char* op = "rasterize_ranges";
  return detail::rasterize_images(clip, triangles, detail::check_ranges(clip, triangles, ranges, options, op),
                                  options, nullptr, op);
}

Tensor interpolate_batch(const Tensor& attributes, const GBuffer& gbuffer, const Tensor& triangles,
                         const InterpolateOptions& options) {
  const std::string op = "interpolate_batch";
  const std::int64_t B = gbuffer.tri_id.defined() && gbuffer.tri_id.rank() == 3 ? gbuffer.tri_id.size(0) : 0;
  if (!gbuffer.clip.defined())
    throw ValueError(op + ": argument 'gbuffer' does not record its clip positions (pass the result of "
                     "rasterize_batch or rasterize_ranges)");
  const Tensor& clip = gbuffer.clip;
  const std::int64_t N = clip.size(clip.rank() - 2);
  const PerImage attr = per_image(attributes, B, N, op, "attributes", "[N, C] or [B, N, C]");
  detail::check_triangles(triangles, N, op);
  check_batched_gbuffer(gbuffer, B, clip, triangles, op);
  detail::check_same_dtype(attributes, clip, op, "attributes", "gbuffer.clip");
  detail::check_finite(attributes, op, "attributes");
  const std::int64_t C = attr.cols;
  if (options.background.defined()) {
    detail::check_same_dtype(options.background, attributes, op, "background", "attributes");
    detail::check_shape(options.background, Shape{C}, op, "background");
  }
  const std::int64_t h = gbuffer.tri_id.size(1), w = gbuffer.tri_id.size(2), P = h * w;
  const Tensor tri_id = gbuffer.tri_id, uv = gbuffer.uv, background = options.background;
  auto params = [=](auto tag, const PerImage& a, std::int64_t b) {
    using T = decltype(tag);
    raster::BarycentricInterpolateParams<T> p;
    p.attr = a.at<T>(b);
    p.num_vertices = N;
    p.channels = C;
    p.tris = triangles.data<std::int32_t>();
    p.num_tris = triangles.size(0);
    p.rast = uv.data<T>() + 2 * b * P;  // the GBuffer's planes: uv and int32 ids
    p.rast_stride = 2;
    p.tri_id = tri_id.data<std::int32_t>() + b * P;
    p.pixels = P;
    return p;
  };
  // The G-buffer's backend (float32), image by image in image order.
  const std::shared_ptr<const raster::RasterBackend> backend =
      attributes.dtype() == DType::Float32 ? gbuffer.backend : nullptr;
  const std::shared_ptr<const GBuffer> made = backend && gbuffer.resident ? std::make_shared<const GBuffer>(gbuffer)
                                                                          : nullptr;
  Tensor out = Tensor::empty({B, h, w, C}, attributes.dtype());
  // On the backend: what each image's forward left on the device, for its adjoint.
  auto kept = std::make_shared<std::vector<std::shared_ptr<const raster::DeviceForward>>>(B);
  dispatch_float(attributes.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    std::vector<char> on_backend(static_cast<std::size_t>(B), 0);
    if constexpr (std::is_same_v<T, float>)
      if (backend) {
        raster::DeferredCalls deferred(backend.get());
        for (std::int64_t b = 0; b < B; ++b)
          on_backend[b] = on_device(backend, made.get(), b, params(tag, attr, b), triangles, [&](const auto& on,
                                                                                                const auto& p) {
            float* o = out.data<float>() + b * P * C;
            return backend->interpolate_forward(on.device, p, int(w), int(h), o, nullptr, &(*kept)[b]);
          });
        deferred.finish();
      }
    for_each_image(B, [&](std::int64_t b) {
      T* o = out.data<T>() + b * P * C;
      if (!on_backend[b]) raster::barycentric_interpolate_forward(params(tag, attr, b), o, static_cast<T*>(nullptr));
      if (!background.defined()) return;
      const std::int32_t* id = tri_id.data<std::int32_t>() + b * P;
      for (std::int64_t q = 0; q < P; ++q)
        if (id[q] == 0) std::copy(background.data<T>(), background.data<T>() + C, o + q * C);
    });
  });
  if (should_record({attributes, uv})) {
    // triangles and tri_id: no gradient, checked for in-place writes (autodiff/tape.h).
    record("interpolate_batch", {attributes, uv, triangles, tri_id}, {&out},
           [attributes, attr, params, B, P, w, h, backend, made, triangles, kept](AdjointContext& ctx) {
             PerImage a = attr;
             a.t = &attributes;
             dispatch_float(attributes.dtype(), "interpolate_batch", [&](auto tag) {
               using T = decltype(tag);
               GradOf g_attr(a, ctx.needs_grad(0) ? B : 0);
               Tensor g_uv = ctx.accumulation_buffer(1);  // the kernel adds (+=)
               auto grads = [&](std::int64_t b) {
                 raster::BarycentricInterpolateGrads<T> g;
                 if (ctx.needs_grad(0)) g.attr = g_attr.at<T>(a, b);
                 if (g_uv.defined()) g.rast = g_uv.data<T>() + 2 * b * P;
                 return g;
               };
               std::vector<char> on_backend(static_cast<std::size_t>(B), 0);
               if constexpr (std::is_same_v<T, float>)
                 if (backend) {
                   raster::DeferredCalls deferred(backend.get());
                   for (std::int64_t b = 0; b < B; ++b)
                     on_backend[b] = on_device(backend, made.get(), b, params(tag, a, b), triangles,
                                               [&](const auto& on, const auto& p) {
                                                 const float* go = ctx.grad_output().data<float>() + b * P * a.cols;
                                                 return backend->interpolate_backward(on.device, p, int(w), int(h),
                                                                                      go, nullptr, grads(b),
                                                                                      (*kept)[b].get());
                                               });
                   deferred.finish();
                 }
               for_each_image(B, [&](std::int64_t b) {
                 if (on_backend[b]) return;
                 raster::barycentric_interpolate_backward(params(tag, a, b),
                                                          ctx.grad_output().data<T>() + b * P * a.cols, static_cast<const T*>(nullptr), grads(b));
               });
               if (ctx.needs_grad(0)) ctx.accumulate(0, g_attr.finish<T>());
             });
           });
  }
  return out;
}

Tensor antialias_batch(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                       const AntialiasOptions& options) {
  const char* name = options.visibility ? "visibility_antialias_batch" : "antialias_batch";  // the tape keeps it
  const std::string op = name;
  detail::check_float(clip, op, "clip");
  detail::check_float(image, op, "image");
  if (image.rank() != 4 || image.size(3) < 1)
    throw ShapeError(op + ": argument 'image' must have shape [B, H, W, C], got " + image.describe());
  const std::int64_t B = image.size(0), h = image.size(1), w = image.size(2), C = image.size(3), P = h * w;
  const std::int64_t N = clip.rank() >= 2 ? clip.size(clip.rank() - 2) : 0;
  const PerImage pos = per_image(clip, B, N, op, "clip", "[N, 4] or [B, N, 4]");
  if (pos.cols != 4) throw ShapeError(op + ": argument 'clip' must have 4 columns, got " + clip.describe());
  detail::check_same_dtype(image, clip, op, "image", "clip");
  detail::check_triangles(triangles, N, op);
  check_batched_gbuffer(gbuffer, B, clip, triangles, op);
  if (gbuffer.tri_id.size(1) != h || gbuffer.tri_id.size(2) != w)
    throw ShapeError(op + ": argument 'gbuffer' " + gbuffer.tri_id.describe() + " and 'image' " + image.describe() +
                     " differ in size");
  detail::check_finite(clip, op, "clip");
  const double boost = options.pos_gradient_boost;
  if (!std::isfinite(boost))
    throw ValueError(op + ": option 'pos_gradient_boost' must be finite, got " + std::to_string(boost));
  if (options.topology && options.topology->num_tris() != triangles.size(0))
    throw ValueError(op + ": option 'topology' was built for " + std::to_string(options.topology->num_tris()) +
                     " triangles but 'triangles' has " + std::to_string(triangles.size(0)));
  // One topology per distinct position set: the given one, else welded by clip rows.
  const std::int64_t topologies = options.topology ? 0 : pos.shared ? 1 : B;
  std::vector<AntialiasTopology> topology(static_cast<std::size_t>(topologies));
  auto pairs = std::make_shared<std::vector<raster::BlendedPairs>>(static_cast<std::size_t>(B));
  // What the forward and the adjoint both read of image b.
  const bool visibility = options.visibility;
  auto image_params = [=](auto tag, const Tensor& img, const PerImage& c, std::int64_t b) {
    using T = decltype(tag);
    raster::AntialiasParams<T> p;
    p.visibility = visibility;  // read by the backend's calls only
    p.image = img.data<T>() + b * P * C;
    p.channels = static_cast<int>(C);
    p.width = static_cast<int>(w);
    p.height = static_cast<int>(h);
    p.clip = c.at<T>(b);
    p.num_vertices = N;
    return p;
  };
  Tensor out = Tensor::empty(image.shape(), image.dtype());
  const Tensor tri_id = gbuffer.tri_id, depth = gbuffer.depth;
  // The G-buffer's backend runs either kernel (float32), image by image in
  // image order, on the device's copy (a range's too: it reads the whole
  // list, which the topology indexes, with the copy's ids offset by its first row).
  const std::shared_ptr<const raster::RasterBackend> backend =
      clip.dtype() == DType::Float32 ? gbuffer.backend : nullptr;
  const std::shared_ptr<const GBuffer> made = backend && gbuffer.resident ? std::make_shared<const GBuffer>(gbuffer)
                                                                          : nullptr;
  // What the forward and, on the backend, the adjoint read of image b beyond image_params.
  const AntialiasTopology given = options.topology;
  auto gbuffer_params = [tri_id, depth, triangles, P, given](auto& p, std::int64_t b,
                                                             const std::vector<AntialiasTopology>& built, bool shared) {
    using T = std::remove_const_t<std::remove_pointer_t<decltype(p.depth)>>;
    p.tri_id = tri_id.data<std::int32_t>() + b * P;
    p.depth = depth.data<T>() + b * P;
    p.tris = triangles.data<std::int32_t>();
    p.num_tris = triangles.size(0);
    p.topology = given ? given.get() : built[shared ? 0 : b].get();
  };
  bool on_backend = false;
  // On the backend: each image's pairs kept on the device, for its adjoint.
  auto kept_pairs = std::make_shared<std::vector<std::shared_ptr<const raster::DeviceForward>>>(B);
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    for_each_image(topologies, [&](std::int64_t b) {
      topology[b] = detail::welded_topology(triangles, N, pos.at<T>(b));  // kept while its weld holds
    });
    if constexpr (std::is_same_v<T, float>)
      if (backend) {
        on_backend = true;
        raster::DeferredCalls deferred(backend.get());
        for (std::int64_t b = 0; b < B && on_backend; ++b) {
          raster::AntialiasParams<float> p = image_params(tag, image, pos, b);
          gbuffer_params(p, b, topology, pos.shared);
          const detail::ImageOnDevice on = detail::image_on_device(made.get(), b, triangles, p.tri_id, P, true);
          float* o = out.data<float>() + b * P * C;
          on_backend = backend->antialias_forward(on.device, on.first, p, o, &(*kept_pairs)[b]);
        }
        deferred.finish();
        if (on_backend) return;
      }
    for_each_image(B, [&](std::int64_t b) {
      raster::AntialiasParams<T> p = image_params(tag, image, pos, b);
      gbuffer_params(p, b, topology, pos.shared);
      raster::blend_boundaries_forward(options.visibility, p, out.data<T>() + b * P * C, &(*pairs)[b]);
    });
  });
  if (on_backend && should_record({image, clip})) {
    // The backend's adjoint takes the forward's inputs (it reads the pairs it kept, or recomputes them).
    auto built = std::make_shared<const std::vector<AntialiasTopology>>(std::move(topology));
    record(name, {image, clip}, {&out},
           [image = image.detach(), clip = clip.detach(), pos, boost, B, P, C, N, image_params, gbuffer_params, built,
            backend, made, triangles, kept_pairs](AdjointContext& ctx) {
             PerImage c = pos;
             c.t = &clip;
             Tensor g_image = ctx.needs_grad(0) ? Tensor::zeros(image.shape(), image.dtype()) : Tensor();
             GradOf g_clip(c, ctx.needs_grad(1) ? B : 0);
             raster::DeferredCalls deferred(backend.get());
             for (std::int64_t b = 0; b < B; ++b) {  // image order: a shared clip's parts, then their sum
               raster::AntialiasParams<float> p = image_params(float{}, image, c, b);
               gbuffer_params(p, b, *built, c.shared);
               raster::AntialiasGrads<float> g;
               if (g_image.defined()) g.image = g_image.data<float>() + b * P * C;
               if (ctx.needs_grad(1)) g.clip = g_clip.at<float>(c, b);
               const detail::ImageOnDevice on = detail::image_on_device(made.get(), b, triangles, p.tri_id, P, true);
               const float* go = ctx.grad_output().data<float>() + b * P * C;
               if (!backend->antialias_backward(on.device, on.first, p, go, g, (*kept_pairs)[b].get()))
                 throw Error("antialias_batch: the backend ran the forward but refused the adjoint");
             }
             deferred.finish();
             if (ctx.needs_grad(1) && boost != 1.0)
               for (std::int64_t b = 0; b < B; ++b) {
                 float* g = g_clip.at<float>(c, b);
                 for (std::int64_t i = 0; i < 4 * N; ++i) g[i] = static_cast<float>(boost * g[i]);
               }
             if (g_image.defined()) ctx.accumulate(0, g_image);
             if (ctx.needs_grad(1)) ctx.accumulate(1, g_clip.finish<float>());
           });
  } else if (should_record({image, clip})) {
    record(name, {image, clip}, {&out},
           [image = image.detach(), clip = clip.detach(), pos, pairs, boost, B, P, C, N, image_params, name](
               AdjointContext& ctx) {
             PerImage c = pos;
             c.t = &clip;
             dispatch_float(clip.dtype(), name, [&](auto tag) {
               using T = decltype(tag);
               Tensor g_image = ctx.needs_grad(0) ? Tensor::zeros(image.shape(), image.dtype()) : Tensor();
               GradOf g_clip(c, ctx.needs_grad(1) ? B : 0);
               for_each_image(B, [&](std::int64_t b) {
                 const raster::AntialiasParams<T> p = image_params(tag, image, c, b);
                 raster::AntialiasGrads<T> g;
                 if (g_image.defined()) g.image = g_image.data<T>() + b * P * C;
                 if (ctx.needs_grad(1)) g.clip = g_clip.at<T>(c, b);
                 raster::blend_boundaries_backward(p, (*pairs)[b], ctx.grad_output().data<T>() + b * P * C, g);
                 if (g.clip && boost != 1.0)
                   for (std::int64_t i = 0; i < 4 * N; ++i) g.clip[i] = static_cast<T>(boost * g.clip[i]);
               });
               if (g_image.defined()) ctx.accumulate(0, g_image);
               if (ctx.needs_grad(1)) ctx.accumulate(1, g_clip.finish<T>());
             });
           });
  }
  return out;
}

}  // namespace gr
