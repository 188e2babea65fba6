// Tape op over raster::texture_forward / texture_backward (and mip_build for
// trilinear filtering): the arguments checked, the mip levels prepared, the
// images' lookups run and their adjoint recorded.
#include "ops/render/texture.h"

#include <array>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "autodiff/tape.h"
#include "ops/render/batch.h"
#include "ops/render/resident_texture.h"
#include "ops/tensor/broadcast.h"
#include "ops/check.h"
#include "ops/tensor/shape_ops.h"
#include "raster/image_batch.h"
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

// One call's lookups as the kernels see them: the inputs they read (uv_dx and
// uv_dy for the mipmapped filters only; the gradients of those come through
// the LOD), mip levels 1.. of each texture, and how samples meet textures.
struct Lookups {
  Tensor tex, uv, dx, dy, bias;
  Tensor pyramid;  // [textures, upper]: the user's levels or the built ones; undefined with one level
  bool user_pyramid = false;
  std::vector<Tensor> mip;  // the user's levels (detached), for the backend's resident copies
  raster::MipLayout layout;
  TextureOptions options;
  Batch batch;
  std::int64_t upper = 0;  // values in levels 1.. of one texture
};

// The kernel's view of image b of one call.
template <class T>
raster::TextureParams<T> params(const Lookups& l, std::int64_t b) {
  const Tensor& tex = l.tex;
  const raster::MipLayout& layout = l.layout;
  const std::int64_t C = tex.size(tex.rank() - 1), S = l.batch.samples, t = l.batch.texture_of(b);
  const std::int64_t base = std::int64_t(layout.levels[0].height) * layout.levels[0].width * C;
  raster::TextureParams<T> p;
  p.tex = tex.data<T>() + t * base;
  p.pyramid = l.pyramid.defined() ? l.pyramid.data<T>() + t * (layout.total_texels * C - base) : nullptr;
  p.user_pyramid = l.user_pyramid;
  p.layout = layout;
  p.channels = C;
  p.uv = l.uv.data<T>() + 2 * S * b;
  p.uv_dx = l.dx.defined() ? l.dx.data<T>() + 2 * S * b : nullptr;
  p.uv_dy = l.dy.defined() ? l.dy.data<T>() + 2 * S * b : nullptr;
  p.mip_level_bias = l.bias.defined() ? l.bias.data<T>() + S * b : nullptr;
  p.num_samples = S;
  p.filter = l.options.filter;
  p.wrap = l.options.wrap;
  p.lod_rule = l.options.lod_rule;
  return p;
}

// Runs call(handle) with texture t's device copy on the backend
// (ops/render/resident_texture.h: the forward's, the adjoint's and later
// calls' one while tex and the user's levels are unchanged).
template <class Call>
bool on_backend(const Lookups& l, std::int64_t t, Call call) {
  const std::shared_ptr<detail::ResidentTexture> slot =
      detail::resident_texture(l.options.backend.get(), l.tex, t, l.layout.count(), l.mip);
  std::lock_guard<std::mutex> lock(slot->mutex);
  return call(slot->device);
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

// ---------------------------------------------------------------- forward

// tex: float, [Ht, Wt, C] or [B, Ht, Wt, C], no side above kMaxTextureSize.
void check_tex(const Tensor& tex) {
  detail::check_float(tex, "texture", "tex");
  if (!(tex.rank() == 3 || tex.rank() == 4) || tex.numel() < 1)
    throw ShapeError("texture: argument 'tex' must have shape [Ht, Wt, C] or [B, Ht, Wt, C] with every size >= 1, "
                     "got " + tex.describe());
  const std::int64_t th = tex.size(tex.rank() - 3), tw = tex.size(tex.rank() - 2);
  if (th > kMaxTextureSize || tw > kMaxTextureSize)
    throw ValueError("texture: argument 'tex' " + tex.describe() + " is larger than " +
                     std::to_string(kMaxTextureSize) + " texels per side");
}

// uv: tex's dtype, [..., 2] ([B, ..., 2] with a texture per image, B agreeing
// with tex's unless that is 1); returns how the samples meet the textures.
Batch check_uv(const Tensor& uv, const Tensor& tex) {
  detail::check_float(uv, "texture", "uv");
  detail::check_same_dtype(uv, tex, "texture", "uv", "tex");
  if (uv.rank() < 1 || uv.size(uv.rank() - 1) != 2)
    throw ShapeError("texture: argument 'uv' must have shape [..., 2], got " + uv.describe());
  Batch batch;
  if (tex.rank() == 4) {  // a texture per image (or one shared: B = 1)
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
  return batch;
}

// What sets the level of detail: max_mip_level, uv_dx and uv_dy (needed by
// the mipmapped filters) and mip_level_bias (mipmapped only, uv's shape
// without its last axis).
void check_lod_inputs(const TextureOptions& options, const Tensor& uv, const Tensor& uv_dx, const Tensor& uv_dy,
                      const Tensor& mip_level_bias) {
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
}

// Mip levels 1.. of each texture, [textures, upper]: the user's, copied into
// one buffer, or box-filtered from tex; undefined for a single level.
Tensor mip_pyramid(const Lookups& l, const std::vector<Tensor>& mip) {
  if (l.user_pyramid) {
    NoGradGuard no_grad;
    std::vector<Tensor> rows;
    for (const Tensor& level : mip)
      rows.push_back(reshape(level.detach(), {l.batch.textures, level.numel() / l.batch.textures}));
    return concat(rows, 1);
  }
  if (l.layout.count() == 1) return Tensor();
  // A backend that builds the levels on its device gets level 0 alone.
  if (l.options.backend && l.options.backend->builds_mip_levels() && l.tex.dtype() == DType::Float32)
    return Tensor();
  const Tensor& tex = l.tex;
  const std::int64_t th = tex.size(tex.rank() - 3), tw = tex.size(tex.rank() - 2), C = tex.size(tex.rank() - 1);
  Tensor pyramid = Tensor::empty({l.batch.textures, l.upper}, tex.dtype());
  dispatch_float(tex.dtype(), "texture", [&](auto tag) {
    using T = decltype(tag);
    raster::for_each_image(l.batch.textures, [&](std::int64_t t) {
      raster::mip_build(tex.data<T>() + t * th * tw * C, C, l.layout, pyramid.data<T>() + t * l.upper);
    });
  });
  return pyramid;
}

// The checked arguments as the kernels read them: NaN / Inf refused, the mip
// layout, the user's mip stack checked, and the mip levels.
Lookups prepare_lookups(const Tensor& tex, const Tensor& uv, const TextureOptions& options, const Tensor& uv_dx,
                        const Tensor& uv_dy, const Tensor& mip_level_bias, const std::vector<Tensor>& mip,
                        const Batch& batch) {
  const bool trilinear = raster::mipmapped(options.filter);
  Lookups l;
  l.tex = tex;
  l.uv = uv;
  // The kernel reads these (trilinear only); their gradients come through the LOD.
  l.dx = trilinear ? uv_dx.detach() : Tensor();
  l.dy = trilinear ? uv_dy.detach() : Tensor();
  l.bias = mip_level_bias.defined() ? mip_level_bias.detach() : Tensor();
  if (tex.rank() == 4) {
    // Here, not in the kernel, so that the element named is the tensor's (the
    // kernel sees one image's slice).
    detail::check_finite(tex, "texture", "tex");
    detail::check_finite(uv, "texture", "uv");
    for (auto [t, name] : {std::pair{&l.dx, "uv_dx"}, {&l.dy, "uv_dy"}, {&l.bias, "mip_level_bias"}})
      if (t->defined()) detail::check_finite(*t, "texture", name);
  }
  const std::int64_t th = tex.size(tex.rank() - 3), tw = tex.size(tex.rank() - 2), C = tex.size(tex.rank() - 1);
  l.user_pyramid = !mip.empty();
  const int max_level = !trilinear ? 0 : l.user_pyramid ? static_cast<int>(mip.size()) : options.max_mip_level;
  l.layout = raster::mip_layout(static_cast<int>(th), static_cast<int>(tw), max_level);
  if (l.user_pyramid) check_mip_stack(mip, tex, l.layout, options);
  l.options = options;
  l.batch = batch;
  l.upper = (l.layout.total_texels - th * tw) * C;
  l.pyramid = mip_pyramid(l, mip);
  for (const Tensor& level : mip) l.mip.push_back(level.detach());
  return l;
}

// out = every image's lookups, images in parallel; uv_jacobian (when defined)
// = their d out/d(u, v).
void run_lookups(const Lookups& l, Tensor& out, Tensor& uv_jacobian) {
  const std::int64_t S = l.batch.samples, C = l.tex.size(l.tex.rank() - 1);
  dispatch_float(l.tex.dtype(), "texture", [&](auto tag) {
    using T = decltype(tag);
    raster::for_each_image(l.batch.images, [&](std::int64_t b) {
      if constexpr (std::is_same_v<T, float>)
        if (l.options.backend && on_backend(l, l.batch.texture_of(b), [&](auto& kept) {
              return l.options.backend->texture_forward(params<T>(l, b), out.data<T>() + b * S * C, kept);
            }))
          return;
      raster::texture_forward(params<T>(l, b), out.data<T>() + b * S * C,
                              uv_jacobian.defined() ? uv_jacobian.data<T>() + b * S * 2 * C : nullptr);
    });
  });
}

// ---------------------------------------------------------------- adjoint

// The adjoint's gradient buffers: of tex, uv, uv_dx, uv_dy and mip_level_bias
// (those that need one; nearest: none for uv), and of the user's levels laid
// out as the pyramid ([textures, upper]).
struct GradBuffers {
  std::array<Tensor, 5> inputs;
  Tensor levels;
};

GradBuffers grad_buffers(const AdjointContext& ctx, const Lookups& l) {
  GradBuffers g;
  const Tensor* shape_of[5] = {&l.tex, &l.uv, &l.dx, &l.dy, &l.bias};
  for (std::size_t i = 0; i < 5; ++i)
    if (ctx.needs_grad(i) && !(i == 1 && l.options.filter == Filter::Nearest))
      g.inputs[i] = Tensor::zeros(shape_of[i]->shape(), shape_of[i]->dtype());
  const int user_levels = l.layout.count() - 1;
  bool levels_need_grad = false;
  for (int lv = 0; l.user_pyramid && lv < user_levels; ++lv) levels_need_grad |= ctx.needs_grad(5 + lv);
  if (levels_need_grad) g.levels = Tensor::zeros(l.pyramid.shape(), l.pyramid.dtype());
  return g;
}

// Image b's adjoint; its texture gradients go to g_tex / g_levels at texture t's offset.
template <class T>
void image_backward(const Tensor& grad_out, const Lookups& l, const Tensor& uv_jacobian, GradBuffers& g,
                    std::int64_t b, std::int64_t t, Tensor& g_tex, Tensor& g_levels) {
  const std::int64_t S = l.batch.samples, texels = l.tex.numel() / l.batch.textures;
  const std::int64_t C = l.tex.size(l.tex.rank() - 1);
  auto ptr = [](Tensor& x, std::int64_t offset) { return x.defined() ? x.data<T>() + offset : nullptr; };
  raster::TextureGrads<T> grads;
  grads.tex = ptr(g_tex, t * texels);
  grads.uv = ptr(g.inputs[1], 2 * S * b);
  grads.uv_dx = ptr(g.inputs[2], 2 * S * b);
  grads.uv_dy = ptr(g.inputs[3], 2 * S * b);
  grads.mip_level_bias = ptr(g.inputs[4], S * b);
  grads.pyramid = ptr(g_levels, t * l.upper);
  if constexpr (std::is_same_v<T, float>)
    if (l.options.backend && on_backend(l, l.batch.texture_of(b), [&](auto& kept) {
          return l.options.backend->texture_backward(params<T>(l, b), grad_out.data<T>() + b * S * C, grads, kept);
        }))
      return;
  raster::texture_backward(params<T>(l, b), grad_out.data<T>() + b * S * C, grads,
                           uv_jacobian.defined() ? uv_jacobian.data<T>() + b * S * 2 * C : nullptr);
}

// Every image's adjoint: images in parallel, each into its slices; but a
// texture shared by several images collects their gradients, each image's on
// its own and added in image order (each lookup is parallel inside), as
// separate calls' would sum.
template <class T>
void images_backward(const Tensor& grad_out, const Lookups& l, const Tensor& uv_jacobian, GradBuffers& g) {
  Tensor& g_tex = g.inputs[0];
  const bool shared = l.batch.textures < l.batch.images && (g_tex.defined() || g.levels.defined());
  if (!shared) {
    raster::for_each_image(l.batch.images, [&](std::int64_t b) {
      image_backward<T>(grad_out, l, uv_jacobian, g, b, l.batch.texture_of(b), g_tex, g.levels);
    });
    return;
  }
  for (std::int64_t b = 0; b < l.batch.images; ++b) {
    Tensor part_tex = g_tex.defined() ? Tensor::zeros(g_tex.shape(), g_tex.dtype()) : Tensor();
    Tensor part_levels = g.levels.defined() ? Tensor::zeros(g.levels.shape(), g.levels.dtype()) : Tensor();
    image_backward<T>(grad_out, l, uv_jacobian, g, b, 0, part_tex, part_levels);
    for (auto [total, part] : {std::pair{&g_tex, &part_tex}, std::pair{&g.levels, &part_levels}}) {
      const T* from = part->defined() ? part->template data<T>() : nullptr;
      if (from) raster::sum_in_image_order(&from, 1, total->numel(), total->template data<T>());
    }
  }
}

// The buffers to the inputs' gradients; level l's columns of the levels'
// gradient to mip[l].
void accumulate_grads(AdjointContext& ctx, const Lookups& l, const GradBuffers& g) {
  for (std::size_t i = 0; i < 5; ++i)
    if (g.inputs[i].defined()) ctx.accumulate(i, g.inputs[i]);
  const int user_levels = l.layout.count() - 1;
  std::int64_t column = 0;
  for (int lv = 0; g.levels.defined() && lv < user_levels; ++lv) {
    const raster::MipLevel& level = l.layout.levels[lv + 1];
    const std::int64_t values = std::int64_t(level.height) * level.width * l.tex.size(l.tex.rank() - 1);
    if (ctx.needs_grad(5 + lv))
      ctx.accumulate(5 + lv, reshape(slice(g.levels, 1, column, column + values), level_shape(l.tex, level).dims()));
    column += values;
  }
}

void texture_adjoint(AdjointContext& ctx, const Lookups& l, const Tensor& uv_jacobian) {
  if (!ctx.grad_output().defined()) return;
  GradBuffers g = grad_buffers(ctx, l);
  dispatch_float(l.tex.dtype(), "texture", [&](auto tag) {
    images_backward<decltype(tag)>(ctx.grad_output(), l, uv_jacobian, g);
  });
  accumulate_grads(ctx, l, g);
}

}  // namespace

Tensor texture(const Tensor& tex, const Tensor& uv, const TextureOptions& options, const Tensor& uv_dx,
               const Tensor& uv_dy, const Tensor& mip_level_bias, const std::vector<Tensor>& mip) {
  check_tex(tex);
  const Batch batch = check_uv(uv, tex);
  check_lod_inputs(options, uv, uv_dx, uv_dy, mip_level_bias);
  Lookups lookups = prepare_lookups(tex, uv, options, uv_dx, uv_dy, mip_level_bias, mip, batch);

  const bool trilinear = raster::mipmapped(options.filter);
  const std::int64_t C = tex.size(tex.rank() - 1);
  std::vector<std::int64_t> out_dims = uv.shape().dims();
  out_dims.back() = C;
  Tensor out = Tensor::empty(Shape(out_dims), tex.dtype());
  std::vector<Tensor> inputs{tex, uv, trilinear ? uv_dx : Tensor(), trilinear ? uv_dy : Tensor(), mip_level_bias};
  inputs.insert(inputs.end(), mip.begin(), mip.end());
  const bool recording = should_record(inputs);
  // Bilinear lookups whose uv takes a gradient keep d out/d(u, v) from the
  // forward (2 C values a sample): the adjoint then reads no texel for it
  // (on the CPU; a backend's adjoint takes it from the texels).
  Tensor uv_jacobian;
  const bool on_backend = options.backend && tex.dtype() == DType::Float32;
  if (recording && uv.requires_grad() && options.filter == Filter::Bilinear && !on_backend)
    uv_jacobian = Tensor::empty({batch.images * batch.samples * 2 * C}, tex.dtype());
  run_lookups(lookups, out, uv_jacobian);

  if (recording) {
    lookups.tex = tex.detach();
    lookups.uv = uv.detach();
    record("texture", inputs, {&out}, [l = std::move(lookups), uv_jacobian](AdjointContext& ctx) {
      texture_adjoint(ctx, l, uv_jacobian);
    });
  }
  return out;
}

}  // namespace gr
