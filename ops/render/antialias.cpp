// Tape op over raster::antialias_forward / antialias_backward (or the
// visibility kernels, raster/blended_pairs.h); on the
// G-buffer's backend (RasterBackend::antialias_*) when it has one (float32),
// on the device's copy of the G-buffer while it matches the host's.
#include "ops/render/antialias.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/base/memory.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/render/resident_gbuffer.h"
#include "ops/render/topology_cache.h"
#include "raster/blended_pairs.h"

namespace gr {
namespace {

// Topology of validated triangles (indices in [0, n)); positions may be null.
template <class T>
AntialiasTopology make_topology(const Tensor& triangles, std::int64_t n, const T* positions, int dims) {
  return std::make_shared<const raster::EdgeTopology>(
      raster::build_edge_topology(triangles.data<std::int32_t>(), triangles.size(0), n, positions, dims));
}

// What the adjoint reads: the image [H, W, C], its size and clip. The forward
// adds the G-buffer, the triangles and the topology.
template <class T>
raster::AntialiasParams<T> image_params(const Tensor& image, const Tensor& clip) {
  raster::AntialiasParams<T> p;
  p.image = image.data<T>();
  p.height = int(image.size(0));
  p.width = int(image.size(1));
  p.channels = int(image.size(2));
  p.clip = clip.data<T>();
  p.num_vertices = clip.size(0);
  return p;
}

// Multiplies dL/dclip by nvdiffrast's pos_gradient_boost.
template <class T>
void boost_gradient(Tensor& g_clip, double boost) {
  if (!g_clip.defined() || boost == 1.0) return;
  T* d = g_clip.data<T>();
  for (std::int64_t i = 0; i < g_clip.numel(); ++i) d[i] = static_cast<T>(boost * d[i]);
}

// The adjoint of an antialias run on a backend (float32): the backend's
// antialias_backward, which takes the forward's inputs and the pairs it kept
// (`pairs`; it recomputes them where it no longer holds them).
void record_on_backend(const char* name, bool visibility, const Tensor& image, const GBuffer& gbuffer,
                       const Tensor& clip, const Tensor& triangles, const AntialiasTopology& topology,
                       const std::shared_ptr<const raster::RasterBackend>& backend,
                       std::shared_ptr<const raster::DeviceForward> pairs, double boost, Tensor* out) {
  // The G-buffer, to find the device's copy of it at the adjoint.
  const std::shared_ptr<const GBuffer> made = gbuffer.resident ? std::make_shared<const GBuffer>(gbuffer) : nullptr;
  record(name, {image, clip}, {out},
         [image = image.detach(), clip = clip.detach(), tri_id = gbuffer.tri_id, depth = gbuffer.depth, triangles,
          topology, backend, pairs = std::move(pairs), boost, made, name, visibility](AdjointContext& ctx) {
           const Tensor& g = ctx.grad_output();
           Tensor g_image = ctx.needs_grad(0) ? Tensor::zeros(image.shape(), image.dtype()) : Tensor();
           Tensor g_clip = ctx.needs_grad(1) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
           raster::AntialiasParams<float> p = image_params<float>(image, clip);
           p.tri_id = tri_id.data<std::int32_t>();
           p.depth = depth.data<float>();
           p.tris = triangles.data<std::int32_t>();
           p.num_tris = triangles.size(0);
           p.topology = topology.get();
           p.visibility = visibility;
           auto ptr = [](Tensor& t) { return t.defined() ? t.data<float>() : nullptr; };
           const raster::AntialiasGrads<float> grads{ptr(g_image), ptr(g_clip)};
           const detail::ImageOnDevice on =
               detail::image_on_device(made.get(), 0, triangles, p.tri_id, p.width * std::int64_t(p.height), true);
           if (!backend->antialias_backward(on.device, on.first, p, g.data<float>(), grads, pairs.get()))
             throw Error(std::string(name) + ": the backend ran the forward but refused the adjoint");
           boost_gradient<float>(g_clip, boost);
           if (g_image.defined()) ctx.accumulate(0, g_image);
           if (g_clip.defined()) ctx.accumulate(1, g_clip);
         });
}

}  // namespace

AntialiasTopology antialias_topology(const Tensor& triangles, const Tensor& positions) {
  const std::string op = "antialias_topology";
  if (!positions.defined()) {
    detail::check_dtype(triangles, DType::Int32, op, "triangles");
    detail::check_columns(triangles, 3, op, "triangles", "M");
    // No vertex count: only negative indices are errors, and the tables are
    // sized by the vertices used (never by the largest index).
    detail::check_triangles(triangles, std::int64_t(INT32_MAX) + 1, op);
    check_memory_request(raster::edge_topology_bytes(triangles.size(0)),
                         op + ": the edge adjacency of " + std::to_string(triangles.size(0)) + " triangles");
    return std::make_shared<const raster::EdgeTopology>(
        raster::build_edge_topology(triangles.data<std::int32_t>(), triangles.size(0)));
  }
  detail::check_float(positions, op, "positions");
  if (positions.rank() != 2 || positions.size(1) < 1)
    throw ShapeError(op + ": argument 'positions' must have shape [N, D], got " + positions.describe());
  detail::check_triangles(triangles, positions.size(0), op);
  detail::check_finite(positions, op, "positions");
  return dispatch_float(positions.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    return make_topology(triangles, positions.size(0), positions.data<T>(), static_cast<int>(positions.size(1)));
  });
}

Tensor antialias(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                 const AntialiasOptions& options) {
  const char* name = options.visibility ? "visibility_antialias" : "antialias";  // a literal: the tape keeps it
  const std::string op = name;
  detail::check_clip_and_triangles(clip, triangles, op);
  detail::check_float(image, op, "image");
  if (image.rank() != 3 || image.size(2) < 1)
    throw ShapeError(op + ": argument 'image' must have shape [H, W, C], got " + image.describe());
  detail::check_same_dtype(image, clip, op, "image", "clip");
  if (!gbuffer.tri_id.defined() || gbuffer.tri_id.dtype() != DType::Int32 || gbuffer.tri_id.rank() != 2)
    throw ShapeError(op + ": argument 'gbuffer' has no [H, W] int32 tri_id (pass the result of rasterize)");
  const std::int64_t h = image.size(0), w = image.size(1), c = image.size(2);
  if (gbuffer.tri_id.size(0) != h || gbuffer.tri_id.size(1) != w)
    throw ShapeError(op + ": argument 'gbuffer' is " + std::to_string(gbuffer.tri_id.size(1)) + " x " +
                     std::to_string(gbuffer.tri_id.size(0)) + " pixels but 'image' " + image.describe() +
                     " is " + std::to_string(w) + " x " + std::to_string(h));
  if (!gbuffer.depth.defined() || gbuffer.depth.shape() != Shape{h, w} || gbuffer.depth.dtype() != clip.dtype())
    throw ShapeError(op + ": argument 'gbuffer' depth " + gbuffer.depth.describe() + " must be [" +
                     std::to_string(h) + ", " + std::to_string(w) + "] with the dtype of 'clip'");
  if (c > (std::int64_t(1) << 20))
    throw ShapeError(op + ": argument 'image' has too many channels: " + image.describe());
  detail::check_image_size(w, h, op);
  const std::int64_t m = triangles.size(0), n = clip.size(0);
  detail::check_tri_ids(gbuffer.tri_id, m, op);
  // NaN/Inf clip rows are refused here, naming 'clip' (the default topology
  // below welds by clip rows).
  detail::check_finite(clip, op, "clip");
  detail::check_gbuffer_source(gbuffer, clip, triangles, op);
  const double boost = options.pos_gradient_boost;
  if (!std::isfinite(boost))
    throw ValueError(op + ": option 'pos_gradient_boost' must be finite, got " + std::to_string(boost));
  AntialiasTopology topology = options.topology;
  if (topology && (topology->num_tris() != m || std::int64_t(topology->neighbour().size()) != 3 * m))
    throw ValueError(op + ": option 'topology' was built for " + std::to_string(topology->num_tris()) +
                     " triangles but 'triangles' has " + std::to_string(m));

  Tensor out = Tensor::empty(image.shape(), image.dtype());
  const bool rec = should_record({image, clip});
  auto pairs = std::make_shared<raster::BlendedPairs>();
  // The G-buffer's backend runs either kernel (float32) unless pair counts
  // are asked for (the CPU kernels').
  const bool counted = options.stats || options.visibility_stats;
  const std::shared_ptr<const raster::RasterBackend> backend =
      gbuffer.backend && !counted && clip.dtype() == DType::Float32 ? gbuffer.backend : nullptr;
  bool on_backend = false;
  std::shared_ptr<const raster::DeviceForward> kept_pairs;  // on the backend, for the adjoint
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    // Default topology: weld vertices with equal clip rows (kept for the next
    // call on these triangles while that weld holds: ops/render/topology_cache.h).
    if (!topology) topology = detail::welded_topology(triangles, n, clip.data<T>());
    raster::AntialiasParams<T> p = image_params<T>(image, clip);
    p.tri_id = gbuffer.tri_id.data<std::int32_t>();
    p.depth = gbuffer.depth.data<T>();
    p.tris = triangles.data<std::int32_t>();
    p.num_tris = m;
    p.topology = topology.get();
    p.visibility = options.visibility;
    p.projected = detail::projection_of(gbuffer, clip, static_cast<int>(w), static_cast<int>(h));
    if constexpr (std::is_same_v<T, float>)
      if (backend) {
        const detail::ImageOnDevice on = detail::image_on_device(&gbuffer, 0, triangles, p.tri_id, w * h, true);
        if (backend->antialias_forward(on.device, on.first, p, out.data<T>(), rec ? &kept_pairs : nullptr)) {
          on_backend = true;
          return;
        }
      }
    raster::blend_boundaries_forward(options.visibility, p, out.data<T>(), rec ? pairs.get() : nullptr,
                                     {options.stats, options.visibility_stats});
  });
  if (rec && on_backend) {
    record_on_backend(name, options.visibility, image, gbuffer, clip, triangles, topology, backend,
                      std::move(kept_pairs), boost, &out);
  } else if (rec) {
    record(name, {image, clip}, {&out},
           [image = image.detach(), clip = clip.detach(), pairs, boost, name](AdjointContext& ctx) {
             const Tensor& g = ctx.grad_output();
             Tensor g_image = ctx.needs_grad(0) ? Tensor::zeros(image.shape(), image.dtype()) : Tensor();
             Tensor g_clip = ctx.needs_grad(1) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
             dispatch_float(image.dtype(), name, [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::blend_boundaries_backward(image_params<T>(image, clip), *pairs, g.data<T>(),
                                                 {ptr(g_image), ptr(g_clip)});
               boost_gradient<T>(g_clip, boost);
             });
             if (g_image.defined()) ctx.accumulate(0, g_image);
             if (g_clip.defined()) ctx.accumulate(1, g_clip);
           });
  }
  return out;
}

}  // namespace gr
