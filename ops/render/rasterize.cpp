// Tape op over raster::rasterize_forward (coverage) and
// raster::barycentric_gbuffer_forward / _backward (the values and their adjoint).
#include "ops/render/rasterize.h"

#include <algorithm>
#include <type_traits>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/check.h"
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
  // The coverage kernel's own (screen-space) uv and depth land in gb.uv and
  // gb.depth and are overwritten by finish_gbuffer.
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
  finish_gbuffer(gb, op);
  return gb;
}

void finish_gbuffer(GBuffer& gb, const char* op) {
  const Tensor clip = gb.clip, triangles = gb.triangles;
  const int rank = gb.tri_id.rank();
  const std::int64_t images = rank == 3 ? gb.tri_id.size(0) : 1;
  const int h = static_cast<int>(gb.tri_id.size(rank - 2)), w = static_cast<int>(gb.tri_id.size(rank - 1));
  const std::int64_t P = std::int64_t(h) * w;
  // nvdiffrast's rast (u, v, z/w, id) per pixel, split into uv and depth.
  Tensor rast = Tensor::empty({images * P * 4}, clip.dtype());
  const bool db = gb.db.defined();
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    T* r = rast.data<T>();
    parallel_for(0, images, 1, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t b = lo; b < hi; ++b)
        raster::barycentric_gbuffer_forward(image_params<T>(clip, triangles, b, w, h),
                                            gb.tri_id.data<std::int32_t>() + b * P, 0, r + 4 * P * b,
                                            db ? gb.db.data<T>() + 4 * P * b : nullptr);
    });
    T* uv = gb.uv.data<T>();
    T* depth = gb.depth.data<T>();
    const std::int32_t* id = gb.tri_id.data<std::int32_t>();
    parallel_for(0, images * P, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t q = lo; q < hi; ++q) {
        uv[2 * q] = r[4 * q];
        uv[2 * q + 1] = r[4 * q + 1];
        depth[q] = id[q] ? r[4 * q + 2] : static_cast<T>(raster::kBackgroundDepth);
      }
    });
  });
  if (!should_record({clip})) return;
  std::vector<Tensor*> outputs = {&gb.uv, &gb.depth};
  if (db) outputs.push_back(&gb.db);
  // triangles and tri_id get no gradient; listed so that backward() refuses
  // them written in place since (the adjoint trusts the forward's coverage).
  const Tensor tri_id = gb.tri_id;
  if (images == 1)
    gb.groups = std::make_shared<raster::TriangleGroups>(tri_id.data<std::int32_t>(), std::make_shared<Tensor>(tri_id));
  auto adjoint = [clip, triangles, tri_id, images, w, h, P, db, op, groups = gb.groups,
                  backend = gb.backend](AdjointContext& ctx) {
    const Tensor& g_uv = ctx.grad_output(0);
    const Tensor& g_depth = ctx.grad_output(1);
    const Tensor g_db = db ? ctx.grad_output(2) : Tensor();
    Tensor g = Tensor::zeros(clip.shape(), clip.dtype());
    Tensor g_rast = Tensor::empty({images * P * 4}, clip.dtype());
    dispatch_float(clip.dtype(), op, [&](auto tag) {
      using T = decltype(tag);
      T* gr = g_rast.data<T>();
      const T* gu = g_uv.defined() ? g_uv.data<T>() : nullptr;
      const T* gd = g_depth.defined() ? g_depth.data<T>() : nullptr;
      parallel_for(0, images * P, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t q = lo; q < hi; ++q) {
          gr[4 * q] = gu ? gu[2 * q] : T(0);
          gr[4 * q + 1] = gu ? gu[2 * q + 1] : T(0);
          gr[4 * q + 2] = gd ? gd[q] : T(0);
          gr[4 * q + 3] = T(0);
        }
      });
      // Image by image, in image order: a shared clip's sum is the same for any thread count.
      const std::int64_t n = clip.size(clip.rank() - 2);
      // The coverage from tri_id (int32: exact for any triangle count, unlike float32 ids).
      for (std::int64_t b = 0; b < images; ++b) {
        raster::BarycentricGBufferParams<T> p = image_params<T>(clip, triangles, b, w, h);
        p.tri_id = tri_id.data<std::int32_t>() + b * P;
        p.groups = groups.get();
        if constexpr (std::is_same_v<T, float>)
          if (backend && images == 1 &&
              backend->gbuffer_backward(p, gr, g_db.defined() ? g_db.data<T>() : nullptr, g.data<T>()))
            continue;
        raster::barycentric_gbuffer_backward(p, static_cast<const T*>(nullptr), gr + 4 * P * b,
                                             g_db.defined() ? g_db.data<T>() + 4 * P * b : nullptr,
                                             g.data<T>() + (clip.rank() == 3 ? b * n * 4 : 0));
      }
    });
    ctx.accumulate(0, g);
  };
  record(op, {clip, triangles, tri_id}, outputs, adjoint);
}

}  // namespace detail
}  // namespace gr
