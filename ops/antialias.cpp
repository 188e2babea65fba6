// Tape op over raster::antialias_forward / antialias_backward.
#include "ops/antialias.h"

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "ops/broadcast.h"
#include "raster/rasterize_setup.h"  // detail::check_finite

namespace gr {

AntialiasTopology antialias_topology(const Tensor& triangles, const Tensor& positions) {
  const std::string op = "antialias_topology";
  if (!triangles.defined() || triangles.dtype() != DType::Int32)
    throw DTypeError(op + ": argument 'triangles' must be an int32 tensor, got " + triangles.describe());
  if (triangles.rank() != 2 || triangles.size(1) != 3)
    throw ShapeError(op + ": argument 'triangles' must have shape [M, 3], got " + triangles.describe());
  const std::int32_t* tris = triangles.data<std::int32_t>();
  const std::int64_t m = triangles.size(0);
  if (!positions.defined()) {
    std::int64_t n = 0;  // vertex count implied by the indices (negatives are rejected inside)
    for (std::int64_t i = 0; i < 3 * m; ++i) n = std::max<std::int64_t>(n, std::int64_t(tris[i]) + 1);
    return std::make_shared<const raster::EdgeTopology>(raster::build_edge_topology(tris, m, n));
  }
  detail::check_float(positions, op, "positions");
  if (positions.rank() != 2 || positions.size(1) < 1)
    throw ShapeError(op + ": argument 'positions' must have shape [N, D], got " + positions.describe());
  return dispatch_float(positions.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    return std::make_shared<const raster::EdgeTopology>(raster::build_edge_topology(
        tris, m, positions.size(0), positions.data<T>(), static_cast<int>(positions.size(1))));
  });
}

Tensor antialias(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                 const AntialiasOptions& options) {
  const std::string op = "antialias";
  detail::check_clip_and_triangles(clip, triangles, op);
  detail::check_float(image, op, "image");
  if (image.rank() != 3 || image.size(2) < 1)
    throw ShapeError(op + ": argument 'image' must have shape [H, W, C], got " + image.describe());
  if (image.dtype() != clip.dtype())
    throw DTypeError(op + ": argument 'image' " + image.describe() + " and 'clip' " + clip.describe() +
                     " must have the same dtype");
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
  const std::int64_t m = triangles.size(0), n = clip.size(0);
  AntialiasTopology topology = options.topology;
  if (topology && topology->num_tris != m)
    throw ValueError(op + ": option 'topology' was built for " + std::to_string(topology->num_tris) +
                     " triangles but 'triangles' has " + std::to_string(m));

  Tensor out = Tensor::empty(image.shape(), image.dtype());
  const bool rec = should_record({image, clip});
  auto pairs = std::make_shared<std::vector<raster::AntialiasPair>>();
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    // NaN/Inf clip rows are refused here, naming 'clip' (the default topology
    // below would otherwise report them as its 'positions').
    raster::detail::check_finite(clip.data<T>(), 4 * n, "clip", op.c_str());
    // Default topology: weld vertices with equal clip rows (indices are checked there).
    if (!topology)
      topology = std::make_shared<const raster::EdgeTopology>(
          raster::build_edge_topology(triangles.data<std::int32_t>(), m, n, clip.data<T>(), 4));
    raster::antialias_forward(image.data<T>(), int(c), gbuffer.tri_id.data<std::int32_t>(), gbuffer.depth.data<T>(),
                              int(w), int(h), clip.data<T>(), n, triangles.data<std::int32_t>(), m, *topology,
                              out.data<T>(), rec ? pairs.get() : nullptr, options.stats);
  });
  if (rec) {
    record("antialias", {image, clip}, {&out},
           [image = image.detach(), clip = clip.detach(), pairs, w, h](AdjointContext& ctx) {
             const Tensor& g = ctx.grad_output();
             Tensor g_image = ctx.needs_grad(0) ? Tensor::zeros(image.shape(), image.dtype()) : Tensor();
             Tensor g_clip = ctx.needs_grad(1) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
             dispatch_float(image.dtype(), "antialias", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::antialias_backward(image.data<T>(), int(image.size(2)), int(w), int(h), clip.data<T>(),
                                          clip.size(0), *pairs, g.data<T>(), ptr(g_image), ptr(g_clip));
             });
             if (g_image.defined()) ctx.accumulate(0, g_image);
             if (g_clip.defined()) ctx.accumulate(1, g_clip);
           });
  }
  return out;
}

}  // namespace gr
