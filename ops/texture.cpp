// Tape op over raster::texture_forward / texture_backward (and mip_build for
// trilinear filtering).
#include "ops/texture.h"

#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "ops/broadcast.h"
#include "ops/check.h"
#include "ops/shape_ops.h"
#include "raster/mipmap.h"

namespace gr {
namespace {

constexpr std::int64_t kMaxTextureSize = 32768;

void check_derivative(const Tensor& d, const Tensor& uv, const char* name) {
  if (!d.defined())
    throw ValueError(std::string("texture: mipmapped filtering needs argument '") + name +
                     "' (d(uv)/dx and d(uv)/dy per pixel, same shape as uv)");
  detail::check_float(d, "texture", name);
  detail::check_same_dtype(d, uv, "texture", name, "uv");
  detail::check_shape(d, uv.shape(), "texture", name);
}

// The kernel's view of one call.
template <class T>
raster::TextureParams<T> params(const Tensor& tex, const Tensor& uv, const Tensor& uv_dx, const Tensor& uv_dy,
                                const Tensor& bias, const Tensor& pyramid, bool user_pyramid,
                                const raster::MipLayout& layout, const TextureOptions& o) {
  raster::TextureParams<T> p;
  p.tex = tex.data<T>();
  p.pyramid = pyramid.defined() ? pyramid.data<T>() : nullptr;
  p.user_pyramid = user_pyramid;
  p.layout = layout;
  p.channels = tex.size(2);
  p.uv = uv.data<T>();
  p.uv_dx = uv_dx.defined() ? uv_dx.data<T>() : nullptr;
  p.uv_dy = uv_dy.defined() ? uv_dy.data<T>() : nullptr;
  p.mip_level_bias = bias.defined() ? bias.data<T>() : nullptr;
  p.num_samples = uv.numel() / 2;
  p.filter = o.filter;
  p.wrap = o.wrap;
  p.lod_rule = o.lod_rule;
  return p;
}

// The user's mip stack: levels 1.. of tex's chain, each [h_l, w_l, C] as
// mip_layout gives them (nvdiffrast's halving), same dtype as tex.
void check_mip_stack(const std::vector<Tensor>& mip, const Tensor& tex, const raster::MipLayout& layout,
                     const TextureOptions& options) {
  if (!raster::mipmapped(options.filter))
    throw ValueError("texture: argument 'mip' (a mip stack) needs a mipmapped filter");
  if (options.max_mip_level != -1 && options.max_mip_level != static_cast<int>(mip.size()))
    throw ValueError("texture: options.max_mip_level = " + std::to_string(options.max_mip_level) + " disagrees with the " +
                     std::to_string(mip.size()) + " levels of argument 'mip'");
  if (layout.count() != static_cast<int>(mip.size()) + 1)
    throw ValueError("texture: argument 'mip' has " + std::to_string(mip.size()) + " levels but a " + tex.describe() +
                     " texture halves to 1 x 1 in " + std::to_string(layout.count() - 1));
  for (std::size_t i = 0; i < mip.size(); ++i) {
    const std::string name = "mip[" + std::to_string(i) + "]";
    const raster::MipLevel& lv = layout.levels[i + 1];
    detail::check_float(mip[i], "texture", name.c_str());
    detail::check_same_dtype(mip[i], tex, "texture", name.c_str(), "tex");
    detail::check_shape(mip[i], Shape{lv.height, lv.width, tex.size(2)}, "texture", name.c_str());
    detail::check_finite(mip[i], "texture", name.c_str());
  }
}

}  // namespace

Tensor texture(const Tensor& tex, const Tensor& uv, const TextureOptions& options, const Tensor& uv_dx,
               const Tensor& uv_dy, const Tensor& mip_level_bias, const std::vector<Tensor>& mip) {
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
  const bool trilinear = raster::mipmapped(options.filter);  // the filters that read the mip levels
  if (trilinear) {
    check_derivative(uv_dx, uv, "uv_dx");
    check_derivative(uv_dy, uv, "uv_dy");
  }
  if (mip_level_bias.defined()) {
    if (!trilinear)
      throw ValueError("texture: argument 'mip_level_bias' needs a mipmapped filter (it shifts the level of detail)");
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
  const bool user_pyramid = !mip.empty();
  const int max_level = !trilinear ? 0 : user_pyramid ? static_cast<int>(mip.size()) : options.max_mip_level;
  const raster::MipLayout layout = raster::mip_layout(th, tw, max_level);
  if (user_pyramid) check_mip_stack(mip, tex, layout, options);

  // Mip levels 1.. (trilinear: the user's, copied into one buffer, or built), then the lookups.
  Tensor pyramid;
  const std::int64_t base_texels = static_cast<std::int64_t>(th) * tw;
  if (user_pyramid) {
    NoGradGuard no_grad;
    std::vector<Tensor> rows;
    for (const Tensor& level : mip) rows.push_back(reshape(level.detach(), {level.size(0) * level.size(1), C}));
    pyramid = concat(rows, 0);
  } else if (layout.count() > 1) {
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
    raster::texture_forward(params<T>(tex, uv, dx, dy, bias, pyramid, user_pyramid, layout, options), out.data<T>());
  });

  std::vector<Tensor> inputs{tex, uv, trilinear ? uv_dx : Tensor(), trilinear ? uv_dy : Tensor(), mip_level_bias};
  inputs.insert(inputs.end(), mip.begin(), mip.end());
  if (should_record(inputs)) {
    record("texture", inputs, {&out},
           [tex = tex.detach(), uv = uv.detach(), dx, dy, bias, pyramid, user_pyramid, layout,
            options](AdjointContext& ctx) {
             if (!ctx.grad_output().defined()) return;
             // Gradient buffers of the inputs that need one (nearest: none for uv).
             std::vector<Tensor> g(5);
             const Tensor* shape_of[5] = {&tex, &uv, &dx, &dy, &bias};
             for (std::size_t i = 0; i < 5; ++i)
               if (ctx.needs_grad(i) && !(i == 1 && options.filter == Filter::Nearest))
                 g[i] = Tensor::zeros(shape_of[i]->shape(), shape_of[i]->dtype());
             const int user_levels = layout.count() - 1;
             bool levels_need_grad = false;
             for (int l = 0; user_pyramid && l < user_levels; ++l) levels_need_grad |= ctx.needs_grad(5 + l);
             Tensor g_pyramid = levels_need_grad ? Tensor::zeros(pyramid.shape(), pyramid.dtype()) : Tensor();
             dispatch_float(tex.dtype(), "texture", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [&](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::TextureGrads<T> grads;
               grads.tex = ptr(g[0]);
               grads.uv = ptr(g[1]);
               grads.uv_dx = ptr(g[2]);
               grads.uv_dy = ptr(g[3]);
               grads.mip_level_bias = ptr(g[4]);
               grads.pyramid = ptr(g_pyramid);
               raster::texture_backward(params<T>(tex, uv, dx, dy, bias, pyramid, user_pyramid, layout, options),
                                        ctx.grad_output().data<T>(), grads);
             });
             for (std::size_t i = 0; i < 5; ++i)
               if (g[i].defined()) ctx.accumulate(i, g[i]);
             // Level l's rows of the pyramid gradient go to mip[l].
             std::int64_t row = 0;
             for (int l = 0; levels_need_grad && l < user_levels; ++l) {
               const raster::MipLevel& lv = layout.levels[l + 1];
               const std::int64_t rows = std::int64_t(lv.height) * lv.width;
               if (ctx.needs_grad(5 + l))
                 ctx.accumulate(5 + l, reshape(slice(g_pyramid, 0, row, row + rows), {lv.height, lv.width, tex.size(2)}));
               row += rows;
             }
           });
  }
  return out;
}

}  // namespace gr
