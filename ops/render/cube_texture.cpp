// Tape op over raster::cube_texture_forward / cube_texture_backward (and
// cube_mip_build for the mipmapped filters); on a backend, the cube map kept
// on its device across calls (ops/render/resident_texture.h).
#include "ops/render/cube_texture.h"

#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/render/resident_texture.h"
#include "raster/mipmap.h"

namespace gr {
namespace {

constexpr std::int64_t kMaxFaceSize = 32768;

// Shape of dir with its last axis replaced by `last` (or dropped, last < 0).
Shape dir_shape_with(const Tensor& dir, std::int64_t last) {
  std::vector<std::int64_t> dims = dir.shape().dims();
  dims.pop_back();
  if (last >= 0) dims.push_back(last);
  return Shape(dims);
}

// The kernel's view of one call.
template <class T>
raster::CubeTextureParams<T> params(const Tensor& tex, const Tensor& dir, const Tensor& dir_da, const Tensor& bias,
                                    const Tensor& pyramid, const raster::MipLayout& layout,
                                    const CubeTextureOptions& o) {
  raster::CubeTextureParams<T> p;
  p.faces = tex.data<T>();
  p.pyramid = pyramid.defined() ? pyramid.data<T>() : nullptr;
  p.layout = layout;
  p.channels = tex.size(3);
  p.dir = dir.data<T>();
  p.dir_da = dir_da.defined() ? dir_da.data<T>() : nullptr;
  p.mip_level_bias = bias.defined() ? bias.data<T>() : nullptr;
  p.num_samples = dir.numel() / 3;
  p.filter = o.filter;
  return p;
}

// Each face's mip levels 1.. (cube_mip_build), [6 x upper texels, C];
// undefined with one level.
Tensor host_pyramid(const Tensor& tex, const raster::MipLayout& layout) {
  if (layout.count() == 1) return Tensor();
  const std::int64_t C = tex.size(3), base = std::int64_t(layout.levels[0].width) * layout.levels[0].width;
  Tensor pyramid = Tensor::empty({6 * (layout.total_texels - base), C}, tex.dtype());
  dispatch_float(tex.dtype(), "cube_texture", [&](auto tag) {
    using T = decltype(tag);
    raster::cube_mip_build(tex.data<T>(), C, layout, pyramid.data<T>());
  });
  return pyramid;
}

// Runs call(handle) with tex's device copy on the backend (the forward's, the
// adjoint's and later calls' one while tex is unchanged); call returns
// whether the backend ran it.
template <class Call>
bool on_backend(const CubeTextureOptions& o, const Tensor& tex, const raster::MipLayout& layout, Call call) {
  const std::shared_ptr<detail::ResidentTexture> slot =
      detail::resident_texture(o.backend.get(), tex, 0, layout.count(), {}, detail::TextureKind::Cube);
  std::lock_guard<std::mutex> lock(slot->mutex);
  return call(slot->device);
}

}  // namespace

Tensor cube_texture(const Tensor& tex, const Tensor& dir, const CubeTextureOptions& options, const Tensor& dir_da,
                    const Tensor& mip_level_bias) {
  // Arguments.
  detail::check_float(tex, "cube_texture", "tex");
  if (tex.rank() != 4 || tex.size(0) != 6 || tex.size(1) < 1 || tex.size(1) != tex.size(2) || tex.size(3) < 1)
    throw ShapeError("cube_texture: argument 'tex' must have shape [6, S, S, C] (6 square faces) with S, C >= 1, got " +
                     tex.describe());
  if (tex.size(1) > kMaxFaceSize)
    throw ValueError("cube_texture: argument 'tex' " + tex.describe() + " has faces larger than " +
                     std::to_string(kMaxFaceSize) + " texels per side");
  detail::check_float(dir, "cube_texture", "dir");
  detail::check_same_dtype(dir, tex, "cube_texture", "dir", "tex");
  if (dir.rank() < 1 || dir.size(dir.rank() - 1) != 3)
    throw ShapeError("cube_texture: argument 'dir' must have shape [..., 3], got " + dir.describe());
  if (options.max_mip_level < -1)
    throw ValueError("cube_texture: options.max_mip_level must be >= -1 (-1 = all levels), got " +
                     std::to_string(options.max_mip_level));
  const bool mipmapped = raster::is_mipmapped(options.filter);
  if (mipmapped && dir_da.defined()) {
    detail::check_float(dir_da, "cube_texture", "dir_da");
    detail::check_same_dtype(dir_da, dir, "cube_texture", "dir_da", "dir");
    detail::check_shape(dir_da, dir_shape_with(dir, 6), "cube_texture", "dir_da");
  }
  if (mip_level_bias.defined()) {
    if (!mipmapped)
      throw ValueError("cube_texture: argument 'mip_level_bias' needs a mipmapped filter (it shifts the level of detail)");
    detail::check_float(mip_level_bias, "cube_texture", "mip_level_bias");
    detail::check_same_dtype(mip_level_bias, dir, "cube_texture", "mip_level_bias", "dir");
    detail::check_shape(mip_level_bias, dir_shape_with(dir, -1), "cube_texture", "mip_level_bias");
  }
  if (mipmapped && !dir_da.defined() && !mip_level_bias.defined())
    throw ValueError("cube_texture: a mipmapped filter needs argument 'dir_da' (d(dir)/dX, d(dir)/dY per sample, "
                     "[..., 6]) or 'mip_level_bias' (the LOD itself)");
  // The kernel reads these (mipmapped only); their gradients come through the LOD.
  const Tensor da = mipmapped && dir_da.defined() ? dir_da.detach() : Tensor();
  const Tensor bias = mip_level_bias.defined() ? mip_level_bias.detach() : Tensor();
  const int S = static_cast<int>(tex.size(1));
  const std::int64_t C = tex.size(3);
  const raster::MipLayout layout = raster::mip_layout(S, S, mipmapped ? options.max_mip_level : 0);

  // Per-face mip levels 1.. (a backend that builds them on its device gets
  // level 0 alone), then the lookups.
  const bool on_device = options.backend && tex.dtype() == DType::Float32;
  Tensor pyramid = on_device && options.backend->builds_mip_levels() ? Tensor() : host_pyramid(tex, layout);
  const Shape out_shape = dir_shape_with(dir, C);
  Tensor out = Tensor::empty(out_shape, tex.dtype());
  dispatch_float(tex.dtype(), "cube_texture", [&](auto tag) {
    using T = decltype(tag);
    if constexpr (std::is_same_v<T, float>)
      if (on_device && on_backend(options, tex, layout, [&](auto& kept) {
            return options.backend->cube_texture_forward(
                params<T>(tex, dir, da, bias, pyramid, layout, options), out.data<T>(), kept);
          }))
        return;
    if (!pyramid.defined()) pyramid = host_pyramid(tex, layout);
    raster::cube_texture_forward(params<T>(tex, dir, da, bias, pyramid, layout, options), out.data<T>());
  });

  const std::vector<Tensor> inputs{tex, dir, mipmapped ? dir_da : Tensor(), mip_level_bias};
  if (should_record(inputs)) {
    record("cube_texture", inputs, {&out},
           [tex = tex.detach(), dir = dir.detach(), da, bias, pyramid, layout, options](AdjointContext& ctx) {
             if (!ctx.grad_output().defined()) return;
             // Gradient buffers of the inputs that can get one: dir (not
             // nearest), dir_da and the bias (trilinear only); the tape gives
             // zeros to the rest.
             const bool trilinear = options.filter == CubeFilter::Trilinear;
             const Tensor* shape_of[4] = {&tex, &dir, &da, &bias};
             const bool possible[4] = {true, options.filter != CubeFilter::Nearest, trilinear, trilinear};
             std::vector<Tensor> g(4);
             for (std::size_t i = 0; i < 4; ++i)
               if (possible[i] && shape_of[i]->defined() && ctx.needs_grad(i))
                 g[i] = Tensor::zeros(shape_of[i]->shape(), shape_of[i]->dtype());
             dispatch_float(tex.dtype(), "cube_texture", [&](auto tag) {
               using T = decltype(tag);
               auto ptr = [&](Tensor& t) { return t.defined() ? t.data<T>() : nullptr; };
               raster::CubeTextureGrads<T> grads;
               grads.faces = ptr(g[0]);
               grads.dir = ptr(g[1]);
               grads.dir_da = ptr(g[2]);
               grads.mip_level_bias = ptr(g[3]);
               const T* grad_out = ctx.grad_output().data<T>();
               if constexpr (std::is_same_v<T, float>)
                 if (options.backend && on_backend(options, tex, layout, [&](auto& kept) {
                       return options.backend->cube_texture_backward(
                           params<T>(tex, dir, da, bias, pyramid, layout, options), grad_out, grads, kept);
                     }))
                   return;
               const Tensor levels = pyramid.defined() ? pyramid : host_pyramid(tex, layout);
               raster::cube_texture_backward(params<T>(tex, dir, da, bias, levels, layout, options), grad_out, grads);
             });
             for (std::size_t i = 0; i < 4; ++i)
               if (g[i].defined()) ctx.accumulate(i, g[i]);
           });
  }
  return out;
}

}  // namespace gr
