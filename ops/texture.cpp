// Tape op over raster::texture_forward / texture_backward (and mip_build for
// trilinear filtering).
#include "ops/texture.h"

#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "ops/broadcast.h"
#include "raster/mipmap.h"

namespace gr {
namespace {

constexpr std::int64_t kMaxTextureSize = 32768;

void check_derivative(const Tensor& d, const Tensor& uv, const char* name) {
  if (!d.defined())
    throw ValueError(std::string("texture: trilinear filtering needs argument '") + name +
                     "' (d(uv)/dx and d(uv)/dy per pixel, same shape as uv)");
  detail::check_float(d, "texture", name);
  detail::check_same_dtype(d, uv, "texture", name, "uv");
  detail::check_shape(d, uv.shape(), "texture", name);
}

// The kernel's view of one call.
template <class T>
raster::TextureParams<T> params(const Tensor& tex, const Tensor& uv, const Tensor& uv_dx, const Tensor& uv_dy,
                                const Tensor& pyramid, const raster::MipLayout& layout, const TextureOptions& o) {
  raster::TextureParams<T> p;
  p.tex = tex.data<T>();
  p.pyramid = pyramid.defined() ? pyramid.data<T>() : nullptr;
  p.layout = layout;
  p.channels = tex.size(2);
  p.uv = uv.data<T>();
  p.uv_dx = uv_dx.defined() ? uv_dx.data<T>() : nullptr;
  p.uv_dy = uv_dy.defined() ? uv_dy.data<T>() : nullptr;
  p.num_samples = uv.numel() / 2;
  p.filter = o.filter;
  p.wrap = o.wrap;
  return p;
}

}  // namespace

Tensor texture(const Tensor& tex, const Tensor& uv, const TextureOptions& options, const Tensor& uv_dx_in,
               const Tensor& uv_dy_in) {
  // Arguments.
  detail::check_float(tex, "texture", "tex");
  if (tex.rank() != 3 || tex.size(0) < 1 || tex.size(1) < 1 || tex.size(2) < 1)
    throw ShapeError("texture: argument 'tex' must have shape [Ht, Wt, C] with Ht, Wt, C >= 1, got " +
                     tex.describe());
  if (tex.size(0) > kMaxTextureSize || tex.size(1) > kMaxTextureSize)
    throw ValueError("texture: argument 'tex' " + tex.describe() + " is larger than " +
                     std::to_string(kMaxTextureSize) + " texels per side");
  detail::check_float(uv, "texture", "uv");
  detail::check_same_dtype(uv, tex, "texture", "uv", "tex");
  if (uv.rank() < 1 || uv.size(uv.rank() - 1) != 2)
    throw ShapeError("texture: argument 'uv' must have shape [..., 2], got " + uv.describe());
  if (options.max_mip_level < -1)
    throw ValueError("texture: options.max_mip_level must be >= -1 (-1 = all levels), got " +
                     std::to_string(options.max_mip_level));
  const bool trilinear = options.filter == Filter::Trilinear;
  Tensor uv_dx, uv_dy;  // read by trilinear only; stop-gradient
  if (trilinear) {
    check_derivative(uv_dx_in, uv, "uv_dx");
    check_derivative(uv_dy_in, uv, "uv_dy");
    uv_dx = uv_dx_in.detach();
    uv_dy = uv_dy_in.detach();
  }
  const int th = static_cast<int>(tex.size(0)), tw = static_cast<int>(tex.size(1));
  const std::int64_t C = tex.size(2);
  const raster::MipLayout layout = raster::mip_layout(th, tw, trilinear ? options.max_mip_level : 0);

  // Mip levels 1.. (trilinear), then the lookups.
  Tensor pyramid;
  const std::int64_t base_texels = static_cast<std::int64_t>(th) * tw;
  if (layout.count() > 1) {
    pyramid = Tensor::empty({layout.total_texels - base_texels, C}, tex.dtype());
    dispatch_float(tex.dtype(), "texture", [&](auto tag) {
      using T = decltype(tag);
      raster::mip_build(tex.data<T>(), C, layout, pyramid.data<T>());
    });
  }
  std::vector<std::int64_t> out_dims = uv.shape().dims();
  out_dims.back() = C;
  const Shape out_shape(out_dims);
  Tensor out = Tensor::empty(out_shape, tex.dtype());
  dispatch_float(tex.dtype(), "texture", [&](auto tag) {
    using T = decltype(tag);
    raster::texture_forward(params<T>(tex, uv, uv_dx, uv_dy, pyramid, layout, options), out.data<T>());
  });

  if (should_record({tex, uv})) {
    record("texture", {tex, uv}, {&out},
           [tex = tex.detach(), uv = uv.detach(), uv_dx, uv_dy, pyramid, layout, options](AdjointContext& ctx) {
             Tensor g_tex = ctx.needs_grad(0) ? Tensor::zeros(tex.shape(), tex.dtype()) : Tensor();
             Tensor g_uv = ctx.needs_grad(1) && options.filter != Filter::Nearest
                               ? Tensor::zeros(uv.shape(), uv.dtype())
                               : Tensor();
             if ((!g_tex.defined() && !g_uv.defined()) || !ctx.grad_output().defined()) return;
             dispatch_float(tex.dtype(), "texture", [&](auto tag) {
               using T = decltype(tag);
               raster::texture_backward(params<T>(tex, uv, uv_dx, uv_dy, pyramid, layout, options),
                                        ctx.grad_output().data<T>(), g_tex.defined() ? g_tex.data<T>() : nullptr,
                                        g_uv.defined() ? g_uv.data<T>() : nullptr);
             });
             if (g_tex.defined()) ctx.accumulate(0, g_tex);
             if (g_uv.defined()) ctx.accumulate(1, g_uv);
           });
  }
  return out;
}

}  // namespace gr
