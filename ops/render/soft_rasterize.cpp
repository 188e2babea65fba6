// Tape op over raster::soft_rasterize_forward / soft_rasterize_backward.
#include "ops/render/soft_rasterize.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "autodiff/base/dtype.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "raster/soft_rasterize.h"

namespace gr {
namespace {

double positive_scalar(const Tensor& t, const std::string& op, const char* name) {
  detail::check_float(t, op, name);
  if (t.rank() != 0) throw ShapeError(op + ": argument '" + name + "' must be a scalar (rank 0), got " + t.describe());
  const double v = t.item();
  if (!(v > 0.0) || !std::isfinite(v))
    throw ValueError(op + ": argument '" + name + "' must be finite and > 0, got " + std::to_string(v));
  return v;
}

template <class T>
raster::SoftRasterParams<T> params(const Tensor& clip, const Tensor& triangles, const Tensor& attributes,
                                   const Tensor& background, double sigma, double gamma,
                                   const SoftRasterizeOptions& o) {
  raster::SoftRasterParams<T> p;
  p.clip = clip.data<T>();
  p.num_vertices = clip.size(0);
  p.tris = triangles.data<std::int32_t>();
  p.num_tris = triangles.size(0);
  p.attr = attributes.data<T>();
  p.channels = attributes.size(1);
  p.background = background.data<T>();
  p.width = o.width;
  p.height = o.height;
  p.sigma = sigma;
  p.gamma = gamma;
  p.eps = o.eps;
  p.max_faces = o.max_faces;
  return p;
}

}  // namespace

Tensor soft_rasterize(const Tensor& clip, const Tensor& triangles, const Tensor& attributes, const Tensor& sigma,
                      const Tensor& gamma, const SoftRasterizeOptions& options, const Tensor& background_in) {
  const std::string op = "soft_rasterize";
  detail::check_image_size(options.width, options.height, op);
  detail::check_clip_and_triangles(clip, triangles, op);
  detail::check_finite(clip, op, "clip");
  detail::check_float(attributes, op, "attributes");
  detail::check_same_dtype(attributes, clip, op, "attributes", "clip");
  if (attributes.rank() != 2 || attributes.size(0) != clip.size(0) || attributes.size(1) < 1)
    throw ShapeError(op + ": argument 'attributes' must be [N, C] with N = " + std::to_string(clip.size(0)) +
                     " (the rows of 'clip') and C >= 1, got " + attributes.describe());
  detail::check_finite(attributes, op, "attributes");
  const std::int64_t C = attributes.size(1);
  Tensor background = background_in.defined() ? background_in : Tensor::zeros({C}, clip.dtype());
  detail::check_same_dtype(background, clip, op, "background", "clip");
  detail::check_shape(background, Shape{C}, op, "background");
  detail::check_finite(background, op, "background");
  const double s = positive_scalar(sigma, op, "sigma"), g = positive_scalar(gamma, op, "gamma");
  if (options.max_faces < 1 || options.max_faces > 1024)
    throw ValueError(op + ": option 'max_faces' must be in 1..1024, got " + std::to_string(options.max_faces));
  if (!std::isfinite(options.eps)) throw ValueError(op + ": option 'eps' must be finite");
  // The depth scores zs / gamma (zs <= 1) and eps / gamma enter a softmax:
  // an infinite one makes every weight Inf - Inf = NaN.
  if (!std::isfinite(1.0 / g) || !std::isfinite(options.eps / g)) {
    char text[160];
    std::snprintf(text, sizeof text, "%.17g is too small: 1 / gamma and eps / gamma must be finite (eps = %.17g)", g,
                  options.eps);
    throw ValueError(op + ": argument 'gamma' = " + text);
  }

  Tensor out = Tensor::empty({options.height, options.width, C}, clip.dtype());
  dispatch_float(clip.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    raster::soft_rasterize_forward(params<T>(clip, triangles, attributes, background, s, g, options), out.data<T>());
  });
  if (should_record({clip, attributes, background, sigma, gamma})) {
    // triangles: no gradient, checked for in-place writes (autodiff/tape.h).
    record("soft_rasterize", {clip, attributes, background, sigma, gamma, triangles}, {&out},
           [clip = clip.detach(), triangles, attributes = attributes.detach(), background = background.detach(), s, g,
            options, sigma_dtype = sigma.dtype(), gamma_dtype = gamma.dtype()](AdjointContext& ctx) {
             Tensor g_clip = ctx.needs_grad(0) ? Tensor::zeros(clip.shape(), clip.dtype()) : Tensor();
             Tensor g_attr = ctx.needs_grad(1) ? Tensor::zeros(attributes.shape(), attributes.dtype()) : Tensor();
             Tensor g_bg = ctx.needs_grad(2) ? Tensor::zeros(background.shape(), background.dtype()) : Tensor();
             double g_sigma = 0, g_gamma = 0;
             dispatch_float(clip.dtype(), "soft_rasterize", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::SoftRasterGrads<T> grads{ptr(g_clip), ptr(g_attr), ptr(g_bg), ctx.needs_grad(3) ? &g_sigma : nullptr,
                                                ctx.needs_grad(4) ? &g_gamma : nullptr};
               raster::soft_rasterize_backward(params<T>(clip, triangles, attributes, background, s, g, options),
                                               ctx.grad_output().data<T>(), grads);
             });
             if (g_clip.defined()) ctx.accumulate(0, g_clip);
             if (g_attr.defined()) ctx.accumulate(1, g_attr);
             if (g_bg.defined()) ctx.accumulate(2, g_bg);
             if (ctx.needs_grad(3)) ctx.accumulate(3, Tensor::scalar(g_sigma, sigma_dtype));
             if (ctx.needs_grad(4)) ctx.accumulate(4, Tensor::scalar(g_gamma, gamma_dtype));
           });
  }
  return out;
}

}  // namespace gr
