// Tape op over raster::rasterize_forward (coverage) and
// raster::barycentric_gbuffer_forward_planes / _backward (the values and their adjoint).
#include "ops/render/rasterize.h"

#include <algorithm>
#include <type_traits>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/render/resident_gbuffer.h"
#include "raster/barycentric_gbuffer.h"
#include "raster/detail/triangle_groups.h"

namespace gr {
namespace {

// The kernels' view of validated tensors (forward and adjoint alike).
template <class T>
raster::RasterParams<T> params(const Tensor& clip, const Tensor& triangles, const raster::RasterSettings& settings) {
  return {clip.data<T>(), clip.size(0), triangles.data<std::int32_t>(), triangles.size(0), settings};
}

// Image b's view for the barycentric kernels: clip [N, 4] shared or [B, N, 4].
template <class T>
raster::BarycentricGBufferParams<T> image_params(const Tensor& clip, const Tensor& triangles, std::int64_t b,
                                                 int width, int height) {
  const std::int64_t n = clip.size(clip.rank() - 2);
  const T* rows = clip.data<T>() + (clip.rank() == 3 ? b * n * 4 : 0);
  return {rows, n, triangles.data<std::int32_t>(), triangles.size(0), width, height, false};
}

// A G-buffer's images [B, H, W] (or one [H, W]): their count, width, height and pixels each.
struct Images {
  std::int64_t count;
  int width, height;
  std::int64_t pixels;
};
Images images_of(const GBuffer& gb) {
  const int rank = gb.tri_id.rank();
  const int h = static_cast<int>(gb.tri_id.size(rank - 2)), w = static_cast<int>(gb.tri_id.size(rank - 1));
  return {rank == 3 ? gb.tri_id.size(0) : 1, w, h, std::int64_t(h) * w};
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
  gb.backend = options.backend;
  gb.clip = clip;
  gb.triangles = triangles;
  gb.tri_id = Tensor::empty({h, w}, DType::Int32);
  gb.uv = Tensor::empty({h, w, 2}, clip.dtype());
  gb.depth = Tensor::empty({h, w}, clip.dtype());
  if (options.derivatives) gb.db = Tensor::empty({h, w, 4}, clip.dtype());
  if (options.backend && clip.dtype() == DType::Float32) {
    // The whole G-buffer on the backend, kept there for the ops that read it.
    raster::RasterParams<float> p = params<float>(clip, triangles, settings);
    p.floor_id = floor_id;
    p.floor_z = floor_z;
    std::shared_ptr<const raster::DeviceGBuffer> kept = options.backend->rasterize_gbuffer(
        p, gb.tri_id.data<std::int32_t>(), gb.uv.data<float>(), gb.depth.data<float>(),
        options.derivatives ? gb.db.data<float>() : nullptr, key_depth);
    if (kept) {
      gb.resident = keep_resident(std::move(kept), gb);
      record_gbuffer_adjoint(gb, op);
      return gb;
    }
  }
  // The coverage only: finish_gbuffer writes uv and depth (a backend's own
  // screen-space uv and depth land there first and are overwritten).
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    raster::RasterParams<T> p = params<T>(clip, triangles, settings);
    p.floor_id = floor_id;
    p.floor_z = floor_z;
    // The coverage only (finish_gbuffer writes uv and depth).
    T* const no_values = nullptr;
    if (options.backend || clip.size(0) > kKeptProjectionVertices) {
      raster::rasterize_forward_on(options.backend.get(), p, gb.tri_id.data<std::int32_t>(), no_values, no_values,
                                   &gb.stats, key_depth);
      return;
    }
    // On the CPU, keeping the projection for antialias.
    auto kept = std::make_shared<ClipProjection>();
    raster::rasterize_forward(p, gb.tri_id.data<std::int32_t>(), no_values, no_values, &gb.stats, key_depth,
                              &kept->vertices);
    kept->clip = TensorStamp::of(clip);
    kept->width = options.width;
    kept->height = options.height;
    gb.projection = std::move(kept);
  });
  finish_gbuffer(gb, op);
  return gb;
}

const raster::detail::Vertices* projection_of(const GBuffer& gb, const Tensor& clip, int width, int height) {
  const ClipProjection* p = gb.projection.get();
  return p && p->width == width && p->height == height && p->clip.matches(clip) ? p->vertices.get() : nullptr;
}

void finish_gbuffer(GBuffer& gb, const char* op) {
  const Tensor clip = gb.clip, triangles = gb.triangles;
  const Images im = images_of(gb);  // plain names: lambdas below capture them
  const std::int64_t images = im.count, P = im.pixels;
  const int w = im.width, h = im.height;
  // nvdiffrast's rast (u, v, z/w, id) per pixel, written as the planes uv and depth.
  const bool db = gb.db.defined();
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    parallel_for(0, images, 1, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t b = lo; b < hi; ++b)
        raster::barycentric_gbuffer_forward_planes(image_params<T>(clip, triangles, b, w, h),
                                                   gb.tri_id.data<std::int32_t>() + b * P, gb.uv.data<T>() + 2 * P * b,
                                                   gb.depth.data<T>() + P * b, static_cast<T>(raster::kBackgroundDepth),
                                                   db ? gb.db.data<T>() + 4 * P * b : nullptr);
    });
  });
  record_gbuffer_adjoint(gb, op);
}

void record_gbuffer_adjoint(GBuffer& gb, const char* op) {
  const Tensor clip = gb.clip, triangles = gb.triangles;
  const Images im = images_of(gb);  // plain names: lambdas below capture them
  const std::int64_t images = im.count, P = im.pixels;
  const int w = im.width, h = im.height;
  const bool db = gb.db.defined();
  if (!should_record({clip})) return;
  std::vector<Tensor*> outputs = {&gb.uv, &gb.depth};
  if (db) outputs.push_back(&gb.db);
  // triangles and tri_id get no gradient; listed so that backward() refuses
  // them written in place since (the adjoint trusts the forward's coverage).
  const Tensor tri_id = gb.tri_id;
  if (images == 1)
    gb.groups = std::make_shared<raster::TriangleGroups>(tri_id.data<std::int32_t>(), std::make_shared<Tensor>(tri_id));
  // The G-buffer as made, to find the device's copy of it at the adjoint.
  const std::shared_ptr<const GBuffer> made = gb.resident ? std::make_shared<const GBuffer>(gb) : nullptr;
  auto adjoint = [clip, triangles, tri_id, images, w, h, P, db, op, groups = gb.groups, backend = gb.backend,
                  made](AdjointContext& ctx) {
    const Tensor& g_uv = ctx.grad_output(0);
    const Tensor& g_depth = ctx.grad_output(1);
    const Tensor g_db = db ? ctx.grad_output(2) : Tensor();
    Tensor g = Tensor::zeros(clip.shape(), clip.dtype());
    dispatch_float(clip.dtype(), op, [&](auto tag) {
      using T = decltype(tag);
      const T* gu = g_uv.defined() ? g_uv.data<T>() : nullptr;
      const T* gd = g_depth.defined() ? g_depth.data<T>() : nullptr;
      // Image by image, in image order: a shared clip's sum is the same for any thread count.
      const std::int64_t n = clip.size(clip.rank() - 2);
      // The coverage from tri_id (int32: exact for any triangle count, unlike float32 ids);
      // the gradients read from the uv and depth planes as they are.
      std::vector<float> gr;  // a backend's H x W x 4 gradient, reused image by image (read at each call)
      // The backend's calls deferred: the device runs one image while the host prepares the next.
      raster::DeferredCalls deferred(std::is_same_v<T, float> ? backend.get() : nullptr);
      for (std::int64_t b = 0; b < images; ++b) {
        raster::BarycentricGBufferParams<T> p = image_params<T>(clip, triangles, b, w, h);
        p.tri_id = tri_id.data<std::int32_t>() + b * P;
        p.groups = groups.get();
        if constexpr (std::is_same_v<T, float>)
          if (backend) {
            // The device's adjoint reads nvdiffrast's H x W x 4 layout (u, v, z/w, id);
            // none when uv and depth get no gradient.
            if (gu || gd) {
              gr.assign(static_cast<std::size_t>(4 * P), 0.0f);
              for (std::int64_t q = 0; q < P; ++q) {
                if (gu) gr[4 * q] = gu[2 * P * b + 2 * q], gr[4 * q + 1] = gu[2 * P * b + 2 * q + 1];
                if (gd) gr[4 * q + 2] = gd[P * b + q];
              }
            }
            const float* grast = gu || gd ? gr.data() : nullptr;
            const float* gdb = g_db.defined() ? g_db.data<T>() + 4 * P * b : nullptr;
            // Image b as its copy on the device drew it (a range's triangles).
            const ImageOnDevice on = image_on_device(made.get(), b, triangles, p.tri_id, P, false);
            raster::BarycentricGBufferParams<float> pb = p;
            pb.tris = on.tris;
            pb.num_tris = on.num_tris;
            pb.tri_id = on.ids();
            float* gc = g.data<T>() + (clip.rank() == 3 ? b * n * 4 : 0);  // a shared clip's: added in image order
            if (backend->gbuffer_backward(on.device, pb, grast, gdb, gc))
              continue;
          }
        deferred.finish();  // a shared clip's parts are added in image order
        raster::barycentric_gbuffer_backward_planes(p, gu ? gu + 2 * P * b : nullptr, gd ? gd + P * b : nullptr,
                                                    g_db.defined() ? g_db.data<T>() + 4 * P * b : nullptr,
                                                    g.data<T>() + (clip.rank() == 3 ? b * n * 4 : 0));
      }
      deferred.finish();
    });
    ctx.accumulate(0, g);
  };
  record(op, {clip, triangles, tri_id}, outputs, adjoint);
}

}  // namespace detail
}  // namespace gr
