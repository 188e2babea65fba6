// Tape op over raster::visibility_antialias_forward / _backward.
#include "ops/visibility_antialias.h"

#include <memory>
#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "ops/check.h"

namespace gr {
namespace {

// What the adjoint reads: the image [H, W, C], its size and clip.
template <class T>
raster::VisibilityAntialiasParams<T> image_params(const Tensor& image, const Tensor& clip) {
  raster::VisibilityAntialiasParams<T> p;
  p.image = image.data<T>();
  p.height = int(image.size(0));
  p.width = int(image.size(1));
  p.channels = int(image.size(2));
  p.clip = clip.data<T>();
  p.num_vertices = clip.size(0);
  return p;
}

// The argument checks (antialias's), naming the argument at fault.
void check_inputs(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                  const AntialiasTopology& topology, const std::string& op) {
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
  detail::check_tri_ids(gbuffer.tri_id, triangles.size(0), op);
  detail::check_finite(clip, op, "clip");
  const std::int64_t m = triangles.size(0);
  if (topology && (topology->num_tris != m || std::int64_t(topology->neighbour.size()) != 3 * m))
    throw ValueError(op + ": option 'topology' was built for " + std::to_string(topology->num_tris) +
                     " triangles but 'triangles' has " + std::to_string(m));
}

}  // namespace

Tensor visibility_antialias(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                            const VisibilityAntialiasOptions& options) {
  const std::string op = "visibility_antialias";
  check_inputs(image, gbuffer, clip, triangles, options.topology, op);
  const std::int64_t m = triangles.size(0), n = clip.size(0);
  AntialiasTopology topology = options.topology;

  Tensor out = Tensor::empty(image.shape(), image.dtype());
  const bool rec = should_record({image, clip});
  auto pairs = std::make_shared<std::vector<raster::VisibilityPair>>();
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    // Default topology: weld vertices with equal clip rows.
    if (!topology)
      topology = std::make_shared<const raster::EdgeTopology>(
          raster::build_edge_topology(triangles.data<std::int32_t>(), m, n, clip.data<T>(), 4));
    raster::VisibilityAntialiasParams<T> p = image_params<T>(image, clip);
    p.tri_id = gbuffer.tri_id.data<std::int32_t>();
    p.depth = gbuffer.depth.data<T>();
    p.tris = triangles.data<std::int32_t>();
    p.num_tris = m;
    p.topology = topology.get();
    raster::visibility_antialias_forward(p, out.data<T>(), rec ? pairs.get() : nullptr, options.stats);
  });
  if (rec) {
    record("visibility_antialias", {image, clip}, {&out}, [image = image.detach(), clip = clip.detach(), pairs](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      Tensor g_image = ctx.needs_grad(0) ? Tensor::zeros(image.shape(), image.dtype()) : Tensor();
      Tensor g_clip = ctx.needs_grad(1) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
      dispatch_float(image.dtype(), "visibility_antialias", [&](auto tag) {
        using T = decltype(tag);
        auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
        raster::visibility_antialias_backward(image_params<T>(image, clip), *pairs, g.data<T>(),
                                              {ptr(g_image), ptr(g_clip)});
      });
      if (g_image.defined()) ctx.accumulate(0, g_image);
      if (g_clip.defined()) ctx.accumulate(1, g_clip);
    });
  }
  return out;
}

}  // namespace gr
