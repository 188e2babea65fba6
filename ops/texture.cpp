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
                                const Tensor& bias, const Tensor& pyramid, const raster::MipLayout& layout,
                                const TextureOptions& o) {
  raster::TextureParams<T> p;
  p.tex = tex.data<T>();
  p.pyramid = pyramid.defined() ? pyramid.data<T>() : nullptr;
  p.layout = layout;
  p.channels = tex.size(2);
  p.uv = uv.data<T>();
  p.uv_dx = uv_dx.defined() ? uv_dx.data<T>() : nullptr;
  p.uv_dy = uv_dy.defined() ? uv_dy.data<T>() : nullptr;
  p.mip_level_bias = bias.defined() ? bias.data<T>() : nullptr;
  p.num_samples = uv.numel() / 2;
  p.filter = o.filter;
  p.wrap = o.wrap;
  return p;
}

}  // namespace

Tensor texture(const Tensor& tex, const Tensor& uv, const TextureOptions& options, const Tensor& uv_dx,
               const Tensor& uv_dy, const Tensor& mip_level_bias) {
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
  if (trilinear) {
    check_derivative(uv_dx, uv, "uv_dx");
    check_derivative(uv_dy, uv, "uv_dy");
  }
  if (mip_level_bias.defined()) {
    if (!trilinear)
      throw ValueError("texture: argument 'mip_level_bias' needs trilinear filtering (it shifts the level of detail)");
    detail::check_float(mip_level_bias, "texture", "mip_level_bias");
    detail::check_same_dtype(mip_level_bias, uv, "texture", "mip_level_bias", "uv");
    std::vector<std::int64_t> dims = uv.shape().dims();
    dims.pop_back();
    detail::check_shape(mip_level_bias, Shape(dims), "texture", "mip_level_bias");
  }
  // The kernel reads these (trilinear only); their gradients come through the LOD.
  const Tensor dx = trilinear ? uv_dx.detach() : Tensor(), dy = trilinear ? uv_dy.detach() : Tensor();
  const Tensor bias = mip_level_bias.defined() ? mip_level_bias.detach() : Tensor();
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
    raster::texture_forward(params<T>(tex, uv, dx, dy, bias, pyramid, layout, options), out.data<T>());
  });

  const std::vector<Tensor> inputs{tex, uv, trilinear ? uv_dx : Tensor(), trilinear ? uv_dy : Tensor(), mip_level_bias};
  if (should_record(inputs)) {
    record("texture", inputs, {&out},
           [tex = tex.detach(), uv = uv.detach(), dx, dy, bias, pyramid, layout, options](AdjointContext& ctx) {
             if (!ctx.grad_output().defined()) return;
             // Gradient buffers of the inputs that need one (nearest: none for uv).
             std::vector<Tensor> g(5);
             const Tensor* shape_of[5] = {&tex, &uv, &dx, &dy, &bias};
             for (std::size_t i = 0; i < 5; ++i)
               if (ctx.needs_grad(i) && !(i == 1 && options.filter == Filter::Nearest))
                 g[i] = Tensor::zeros(shape_of[i]->shape(), shape_of[i]->dtype());
             dispatch_float(tex.dtype(), "texture", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [&](std::size_t i) { return g[i].defined() ? g[i].data<T>() : nullptr; };
               raster::TextureGrads<T> grads;
               grads.tex = ptr(0);
               grads.uv = ptr(1);
               grads.uv_dx = ptr(2);
               grads.uv_dy = ptr(3);
               grads.mip_level_bias = ptr(4);
               raster::texture_backward(params<T>(tex, uv, dx, dy, bias, pyramid, layout, options),
                                        ctx.grad_output().data<T>(), grads);
             });
             for (std::size_t i = 0; i < 5; ++i)
               if (g[i].defined()) ctx.accumulate(i, g[i]);
           });
  }
  return out;
}

}  // namespace gr
