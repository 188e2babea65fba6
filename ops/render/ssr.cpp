// The SSR pass as ops (ops/render/ssr.h): G-buffer and compositing are composites of
// existing ops; the trace calls raster::ssr_trace and returns constants.
#include "ops/render/ssr.h"

#include <string>

#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "ops/tensor/elementwise.h"
#include "ops/render/interpolate.h"
#include "ops/tensor/linalg.h"
#include "ops/tensor/shape_ops.h"
#include "ops/render/texture.h"
#include "ops/tensor/vector.h"

namespace gr {

namespace {

void require_shape(const Tensor& t, std::initializer_list<std::int64_t> dims, const char* name) {
  detail::check_defined(t, "ssr_trace", name);
  bool ok = t.rank() == static_cast<int>(dims.size());
  int a = 0;
  for (std::int64_t d : dims) {
    if (ok && d >= 0 && t.size(a) != d) ok = false;
    ++a;
  }
  if (!ok) throw ShapeError(std::string("ssr_trace: argument '") + name + "' has shape " + t.describe());
}

template <class T>
SsrTrace trace_typed(const Tensor& position, const Tensor& normal, const Tensor& mask, const Tensor& projection,
                     const SsrOptions& options, const Tensor& back_z, const Tensor& back_mask) {
  const int H = static_cast<int>(position.size(0)), W = static_cast<int>(position.size(1));
  const DType dt = position.dtype();
  SsrTrace t;
  t.width = W, t.height = H;
  t.hit = Tensor::empty({H, W, 1}, dt);
  t.hit_xy = Tensor::empty({H, W, 2}, dt);
  t.hit_distance = Tensor::empty({H, W, 1}, dt);
  t.hit_position = Tensor::empty({H, W, 3}, dt);
  t.edge_fade = Tensor::empty({H, W, 1}, dt);
  t.distance_fade = Tensor::empty({H, W, 1}, dt);
  raster::SsrParams<T> p;
  p.width = W, p.height = H;
  const std::vector<double> m = projection.to_vector();
  for (int k = 0; k < 16; ++k) p.projection[k] = m[k];
  p.position = position.data<T>();
  p.normal = normal.data<T>();
  p.mask = mask.data<std::int32_t>();
  if (back_z.defined()) {
    p.back_z = back_z.data<T>();
    p.back_mask = back_mask.data<std::int32_t>();
  }
  p.hit = t.hit.data<T>();
  p.hit_xy = t.hit_xy.data<T>();
  p.hit_distance = t.hit_distance.data<T>();
  p.hit_position = t.hit_position.data<T>();
  p.edge_fade = t.edge_fade.data<T>();
  p.distance_fade = t.distance_fade.data<T>();
  t.stats = raster::ssr_trace(p, options);
  // Texture uv of the hit (u = x / W, v = 1 - y / H), so texel x = u W - 0.5 = x - 0.5.
  t.hit_uv = Tensor::empty({H, W, 2}, dt);
  const T* xy = t.hit_xy.data<T>();
  T* uv = t.hit_uv.data<T>();
  for (std::int64_t k = 0; k < std::int64_t(W) * H; ++k) {
    uv[2 * k] = xy[2 * k] / T(W);
    uv[2 * k + 1] = T(1) - xy[2 * k + 1] / T(H);
  }
  return t;
}

}  // namespace

ViewSpaceMesh ssr_view_space(const Tensor& positions, const Tensor& normals, const Tensor& view) {
  ViewSpaceMesh v;
  v.positions = slice(transform_points(positions, view), 1, 0, 3);
  const Tensor R = slice(slice(view, 0, 0, 3), 1, 0, 3);
  v.normals = matmul(normals, transpose(R));
  return v;
}

SsrGBuffer ssr_gbuffer(const Tensor& view_positions, const Tensor& view_normals, const Tensor& colours,
                       const Tensor& triangles, const Tensor& projection, const SsrGBufferOptions& options) {
  detail::check_float(view_positions, "ssr_gbuffer", "view_positions");
  detail::check_same_float(view_positions, view_normals, "ssr_gbuffer");
  detail::check_same_float(view_positions, colours, "ssr_gbuffer");
  if (view_positions.rank() != 2 || view_positions.size(1) != 3 || view_normals.shape() != view_positions.shape() ||
      colours.rank() != 2 || colours.size(0) != view_positions.size(0))
    throw ShapeError("ssr_gbuffer: expected view_positions [N, 3], view_normals [N, 3], colours [N, C]; got " +
                     view_positions.describe() + ", " + view_normals.describe() + ", " + colours.describe());
  SsrGBuffer g;
  const Tensor clip = transform_points(view_positions, projection);
  g.raster = rasterize(clip, triangles, {options.width, options.height, Cull::None});
  g.position = interpolate(view_positions, g.raster, triangles);
  g.normal = normalize(interpolate(view_normals, g.raster, triangles));
  g.colour = interpolate(colours, g.raster, triangles);
  g.mask = g.raster.tri_id;
  if (options.back_faces) {
    // Keep only back faces (Cull::Front drops the front ones): the nearest back face.
    const GBuffer back = rasterize(clip, triangles, {options.width, options.height, Cull::Front});
    const Tensor z = slice(interpolate(view_positions, back, triangles), 2, 2, 3);
    g.back_z = reshape(z, {options.height, options.width}).detach();
    g.back_mask = back.tri_id;
  }
  return g;
}

SsrTrace ssr_trace(const Tensor& position, const Tensor& normal, const Tensor& mask, const Tensor& projection,
                   const SsrOptions& options, const Tensor& back_z, const Tensor& back_mask) {
  require_shape(position, {-1, -1, 3}, "position");
  const std::int64_t H = position.size(0), W = position.size(1);
  require_shape(normal, {H, W, 3}, "normal");
  require_shape(mask, {H, W}, "mask");
  require_shape(projection, {4, 4}, "projection");
  detail::check_float(position, "ssr_trace", "position");
  detail::check_same_float(position, normal, "ssr_trace");
  detail::check_dtype(mask, DType::Int32, "ssr_trace", "mask");
  detail::check_float(projection, "ssr_trace", "projection");
  if (back_z.defined() != back_mask.defined())
    throw ValueError("ssr_trace: back_z and back_mask must be given together");
  if (back_z.defined()) {
    require_shape(back_z, {H, W}, "back_z");
    require_shape(back_mask, {H, W}, "back_mask");
    detail::check_same_dtype(back_z, position, "ssr_trace", "back_z", "position");
    detail::check_dtype(back_mask, DType::Int32, "ssr_trace", "back_mask");
  }
  // The search is a stop-gradient: read the values, record nothing.
  if (position.dtype() == DType::Float64)
    return trace_typed<double>(position, normal, mask, projection, options, back_z, back_mask);
  return trace_typed<float>(position, normal, mask, projection, options, back_z, back_mask);
}

SsrTrace ssr_trace(const SsrGBuffer& g, const Tensor& projection, const SsrOptions& options) {
  return ssr_trace(g.position.detach(), g.normal.detach(), g.mask, projection.detach(), options, g.back_z,
                   g.back_mask);
}

SsrFade ssr_fade(const SsrOptions& o, DType dtype) {
  SsrFade f;
  f.form = o.edge_form;
  f.edge_distance = Tensor::full({1}, o.edge_distance, dtype);
  f.edge_exponent = Tensor::full({1}, o.edge_exponent, dtype);
  f.fade_distance = Tensor::full({1}, o.fade_distance, dtype);
  f.fade_exponent = Tensor::full({1}, o.fade_exponent, dtype);
  return f;
}

Tensor ssr_edge_fade(const SsrTrace& t, const SsrFade& f) {
  // Normalized hit position (a, b) in [0, 1]^2: constants.
  const Tensor a = slice(t.hit_xy, 2, 0, 1) / double(t.width);
  const Tensor b = slice(t.hit_xy, 2, 1, 2) / double(t.height);
  if (f.form == EdgeFade::Circular) {
    const Tensor r = 2.0 * sqrt((a - 0.5) * (a - 0.5) + (b - 0.5) * (b - 0.5));
    return clamp(1.0 - pow(r, f.edge_exponent), 0.0, 1.0);
  }
  const Tensor v = f.edge_distance * (a * (1.0 - a) * b * (1.0 - b));
  return clamp(pow(v, f.edge_exponent), 0.0, 1.0);
}

Tensor ssr_distance_fade(const SsrTrace& t, const SsrFade& f) {
  return clamp(1.0 - pow(t.hit_distance / f.fade_distance, f.fade_exponent), 0.0, 1.0);
}

Tensor ssr_confidence(const SsrTrace& t, const SsrFade& f) {
  return t.hit * ssr_edge_fade(t, f) * ssr_distance_fade(t, f);
}

SsrComposite ssr_composite(const Tensor& colour, const SsrTrace& t, const Tensor& reflectivity, const SsrFade& f) {
  detail::check_float(colour, "ssr_composite", "colour");
  if (colour.rank() != 3 || colour.size(0) != t.height || colour.size(1) != t.width)
    throw ShapeError("ssr_composite: colour must be [" + std::to_string(t.height) + ", " + std::to_string(t.width) +
                     ", C], got " + colour.describe());
  detail::check_same_dtype(colour, t.hit, "ssr_composite", "colour", "trace.hit");
  TextureOptions topt;
  topt.filter = Filter::Bilinear;
  topt.wrap = Wrap::Clamp;
  SsrComposite c;
  // Bilinear lookup of the colour buffer at the (constant) hit uv.
  const Tensor sample = texture(colour, t.hit_uv, topt);
  c.confidence = ssr_confidence(t, f);
  c.reflection = sample * c.confidence;
  const Tensor a = reflectivity * c.confidence;
  c.image = colour + a * (sample - colour);
  return c;
}

}  // namespace gr
