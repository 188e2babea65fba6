// Tape op over raster::texture_forward / texture_backward (and mip_build for
// trilinear filtering).
#include "ops/texture.h"

#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "ops/batch.h"
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

// How a call's samples meet its textures: `images` lookups of `samples`
// samples each (uv's leading axis for tex [B, Ht, Wt, C], else one) on
// `textures` texture images (1: shared by every image).
struct Batch {
  std::int64_t images = 1, textures = 1, samples = 0;
  std::int64_t texture_of(std::int64_t b) const { return textures == 1 ? 0 : b; }
};

// The kernel's view of image b of one call.
template <class T>
raster::TextureParams<T> params(const Tensor& tex, const Tensor& uv, const Tensor& uv_dx, const Tensor& uv_dy,
                                const Tensor& bias, const Tensor& pyramid, bool user_pyramid,
                                const raster::MipLayout& layout, const TextureOptions& o, const Batch& batch,
                                std::int64_t b) {
  const std::int64_t C = tex.size(tex.rank() - 1), S = batch.samples, t = batch.texture_of(b);
  const std::int64_t base = std::int64_t(layout.levels[0].height) * layout.levels[0].width * C;
  raster::TextureParams<T> p;
  p.tex = tex.data<T>() + t * base;
  p.pyramid = pyramid.defined() ? pyramid.data<T>() + t * (layout.total_texels * C - base) : nullptr;
  p.user_pyramid = user_pyramid;
  p.layout = layout;
  p.channels = C;
  p.uv = uv.data<T>() + 2 * S * b;
  p.uv_dx = uv_dx.defined() ? uv_dx.data<T>() + 2 * S * b : nullptr;
  p.uv_dy = uv_dy.defined() ? uv_dy.data<T>() + 2 * S * b : nullptr;
  p.mip_level_bias = bias.defined() ? bias.data<T>() + S * b : nullptr;
  p.num_samples = S;
  p.filter = o.filter;
  p.wrap = o.wrap;
  p.lod_rule = o.lod_rule;
  return p;
}

// tex's leading dims with level l's size: [h_l, w_l, C] or [B, h_l, w_l, C].
Shape level_shape(const Tensor& tex, const raster::MipLevel& lv) {
  std::vector<std::int64_t> dims = tex.shape().dims();
  dims[dims.size() - 3] = lv.height;
  dims[dims.size() - 2] = lv.width;
  return Shape(dims);
}

// The user's mip stack: levels 1.. of tex's chain, each [h_l, w_l, C] (or
// [B, h_l, w_l, C] for tex [B, Ht, Wt, C]) as mip_layout gives them
// (nvdiffrast's halving), same dtype as tex.
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
    detail::check_shape(mip[i], level_shape(tex, lv), "texture", name.c_str());
    detail::check_finite(mip[i], "texture", name.c_str());
  }
}

}  // namespace

Tensor texture(const Tensor& tex, const Tensor& uv, const TextureOptions& options, const Tensor& uv_dx,
               const Tensor& uv_dy, const Tensor& mip_level_bias, const std::vector<Tensor>& mip) {
  // Arguments.
  detail::check_float(tex, "texture", "tex");
  const bool per_image = tex.rank() == 4;  // a texture per image (or one shared: B = 1)
  if (!(tex.rank() == 3 || per_image) || tex.numel() < 1)
    throw ShapeError("texture: argument 'tex' must have shape [Ht, Wt, C] or [B, Ht, Wt, C] with every size >= 1, "
                     "got " + tex.describe());
  const std::int64_t th = tex.size(tex.rank() - 3), tw = tex.size(tex.rank() - 2), C = tex.size(tex.rank() - 1);
  if (th > kMaxTextureSize || tw > kMaxTextureSize)
    throw ValueError("texture: argument 'tex' " + tex.describe() + " is larger than " +
                     std::to_string(kMaxTextureSize) + " texels per side");
  detail::check_float(uv, "texture", "uv");
  detail::check_same_dtype(uv, tex, "texture", "uv", "tex");
  if (uv.rank() < 1 || uv.size(uv.rank() - 1) != 2)
    throw ShapeError("texture: argument 'uv' must have shape [..., 2], got " + uv.describe());
  Batch batch;
  if (per_image) {
    if (uv.rank() < 2)
      throw ShapeError("texture: argument 'uv' must have shape [B, ..., 2] with a texture per image, got " +
                       uv.describe());
    batch.images = uv.size(0);
    batch.textures = tex.size(0);
    if (batch.textures != 1 && batch.textures != batch.images)
      throw ShapeError("texture: argument 'tex' " + tex.describe() + " has " + std::to_string(batch.textures) +
                       " textures but argument 'uv' " + uv.describe() + " has " + std::to_string(batch.images) +
                       " images (B must agree, or tex's be 1)");
  }
  batch.samples = batch.images == 0 ? 0 : uv.numel() / 2 / batch.images;
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
  if (per_image) {
    // Here, not in the kernel, so that the element named is the tensor's (the
    // kernel sees one image's slice).
    detail::check_finite(tex, "texture", "tex");
    detail::check_finite(uv, "texture", "uv");
    for (auto [t, name] : {std::pair{&dx, "uv_dx"}, {&dy, "uv_dy"}, {&bias, "mip_level_bias"}})
      if (t->defined()) detail::check_finite(*t, "texture", name);
  }
  const bool user_pyramid = !mip.empty();
  const int max_level = !trilinear ? 0 : user_pyramid ? static_cast<int>(mip.size()) : options.max_mip_level;
  const raster::MipLayout layout = raster::mip_layout(static_cast<int>(th), static_cast<int>(tw), max_level);
  if (user_pyramid) check_mip_stack(mip, tex, layout, options);

  // Mip levels 1.. of each texture (trilinear: the user's, copied into one
  // buffer, or built), [textures, upper texels * C]; then the lookups.
  Tensor pyramid;
  const std::int64_t upper = (layout.total_texels - th * tw) * C;
  if (user_pyramid) {
    NoGradGuard no_grad;
    std::vector<Tensor> rows;
    for (const Tensor& level : mip)
      rows.push_back(reshape(level.detach(), {batch.textures, level.numel() / batch.textures}));
    pyramid = concat(rows, 1);
  } else if (layout.count() > 1) {
    pyramid = Tensor::empty({batch.textures, upper}, tex.dtype());
    dispatch_float(tex.dtype(), "texture", [&](auto tag) {
      using T = decltype(tag);
      detail::for_each_image(batch.textures, [&](std::int64_t t) {
        raster::mip_build(tex.data<T>() + t * th * tw * C, C, layout, pyramid.data<T>() + t * upper);
      });
    });
  }
  std::vector<std::int64_t> out_dims = uv.shape().dims();
  out_dims.back() = C;
  Tensor out = Tensor::empty(Shape(out_dims), tex.dtype());
  std::vector<Tensor> inputs{tex, uv, trilinear ? uv_dx : Tensor(), trilinear ? uv_dy : Tensor(), mip_level_bias};
  inputs.insert(inputs.end(), mip.begin(), mip.end());
  const bool recording = should_record(inputs);
  // Bilinear lookups whose uv takes a gradient keep d out/d(u, v) from the
  // forward (2 C values a sample): the adjoint then reads no texel for it.
  Tensor uv_jacobian;
  if (recording && uv.requires_grad() && options.filter == Filter::Bilinear)
    uv_jacobian = Tensor::empty({batch.images * batch.samples * 2 * C}, tex.dtype());
  dispatch_float(tex.dtype(), "texture", [&](auto tag) {
    using T = decltype(tag);
    detail::for_each_image(batch.images, [&](std::int64_t b) {
      raster::texture_forward(params<T>(tex, uv, dx, dy, bias, pyramid, user_pyramid, layout, options, batch, b),
                              out.data<T>() + b * batch.samples * C,
                              uv_jacobian.defined() ? uv_jacobian.data<T>() + b * batch.samples * 2 * C : nullptr);
    });
  });

  if (recording) {
    record("texture", inputs, {&out},
           [tex = tex.detach(), uv = uv.detach(), dx, dy, bias, pyramid, user_pyramid, layout, options, batch,
            upper, uv_jacobian](AdjointContext& ctx) {
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
             // A texture shared by several images collects their gradients.
             const bool shared = batch.textures < batch.images && (g[0].defined() || g_pyramid.defined());
             dispatch_float(tex.dtype(), "texture", [&](auto tag) {
               using T = decltype(tag);
               const std::int64_t S = batch.samples, texels = tex.numel() / batch.textures;
               auto ptr = [&](Tensor& t, std::int64_t offset) { return t.defined() ? t.data<T>() + offset : nullptr; };
               // Image b's lookup, its texture gradients into g_tex / g_pyr (offset by its texture).
               auto image = [&](std::int64_t b, Tensor& g_tex, Tensor& g_pyr) {
                 const std::int64_t t = shared ? 0 : batch.texture_of(b);
                 raster::TextureGrads<T> grads;
                 grads.tex = ptr(g_tex, t * texels);
                 grads.uv = ptr(g[1], 2 * S * b);
                 grads.uv_dx = ptr(g[2], 2 * S * b);
                 grads.uv_dy = ptr(g[3], 2 * S * b);
                 grads.mip_level_bias = ptr(g[4], S * b);
                 grads.pyramid = ptr(g_pyr, t * upper);
                 const std::int64_t C = tex.size(tex.rank() - 1);
                 raster::texture_backward(
                     params<T>(tex, uv, dx, dy, bias, pyramid, user_pyramid, layout, options, batch, b),
                     ctx.grad_output().data<T>() + b * S * C, grads,
                     uv_jacobian.defined() ? uv_jacobian.data<T>() + b * S * 2 * C : nullptr);
               };
               if (!shared) {
                 detail::for_each_image(batch.images, [&](std::int64_t b) { image(b, g[0], g_pyramid); });
                 return;
               }
               // Each image's gradient on its own, added in image order (each
               // lookup is parallel inside), as separate calls' would sum.
               auto add = [](Tensor& total, const Tensor& part) {
                 if (!total.defined()) return;
                 T* to = total.data<T>();
                 const T* from = part.data<T>();
                 parallel_for(0, total.numel(), kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
                   for (std::int64_t k = lo; k < hi; ++k) to[k] += from[k];
                 });
               };
               for (std::int64_t b = 0; b < batch.images; ++b) {
                 Tensor part_tex = g[0].defined() ? Tensor::zeros(g[0].shape(), g[0].dtype()) : Tensor();
                 Tensor part_pyr = g_pyramid.defined() ? Tensor::zeros(g_pyramid.shape(), g_pyramid.dtype()) : Tensor();
                 image(b, part_tex, part_pyr);
                 add(g[0], part_tex);
                 add(g_pyramid, part_pyr);
               }
             });
             for (std::size_t i = 0; i < 5; ++i)
               if (g[i].defined()) ctx.accumulate(i, g[i]);
             // Level l's columns of the pyramid gradient go to mip[l].
             std::int64_t column = 0;
             for (int l = 0; levels_need_grad && l < user_levels; ++l) {
               const raster::MipLevel& lv = layout.levels[l + 1];
               const std::int64_t values = std::int64_t(lv.height) * lv.width * tex.size(tex.rank() - 1);
               if (ctx.needs_grad(5 + l))
                 ctx.accumulate(5 + l,
                                reshape(slice(g_pyramid, 1, column, column + values), level_shape(tex, lv).dims()));
               column += values;
             }
           });
  }
  return out;
}

}  // namespace gr
