#include "python/src/texture.h"

#include <string>
#include <type_traits>

#include "autodiff/base/error.h"
#include "python/src/backend.h"
#include "raster/cube_texture.h"
#include "raster/mipmap.h"
#include "raster/mesh_checks.h"
#include "raster/texture.h"

namespace gr::python {

namespace {
constexpr std::int64_t kMaxTextureSide = 32768;
using Objects = const pybind11::object&;
}  // namespace

struct TextureArgs {
  TextureArgs(const TextureMode& mode, Objects tex, Objects uv, Objects uv_dx, Objects uv_dy, Objects bias,
              Objects pyramid, Objects uv_jacobian, const char* op, bool lookups);

  TextureMode mode;
  Array tex, pyramid, uv, uv_dx, uv_dy, bias, uv_jacobian;
  std::int64_t tex_images = 1;  // 1 = broadcast over the minibatch
  int height = 0, width = 0;
  std::int64_t channels = 0;
  raster::MipLayout layout;
  std::int64_t images = 0, samples = 0;

  bool f64() const { return tex.elem() == Elem::F64; }
  // Values of one texture image (2D, or 6 faces), of its levels 1.., of one
  // image's samples.
  std::int64_t texture_values() const { return (mode.cube ? 6 : 1) * height * width * channels; }
  std::int64_t pyramid_values() const {
    const std::int64_t base = static_cast<std::int64_t>(layout.levels[0].height) * layout.levels[0].width;
    return (mode.cube ? 6 : 1) * (layout.total_texels - base) * channels;
  }
};

TextureArgs::TextureArgs(const TextureMode& mode_, Objects tex_, Objects uv_, Objects uv_dx_, Objects uv_dy_,
                         Objects bias_, Objects pyramid_, Objects uv_jacobian_, const char* op, bool lookups)
    : mode(mode_),
      tex(tex_, op, "tex"),
      pyramid(pyramid_, op, "pyramid", true),
      uv(uv_, op, "uv", !lookups),
      uv_dx(uv_dx_, op, mode_.cube ? "uv_da" : "uv_dx", true),
      uv_dy(uv_dy_, op, "uv_dy", true),
      bias(bias_, op, "mip_level_bias", true),
      uv_jacobian(uv_jacobian_, op, "uv_jacobian", true) {
  const std::string o(op);
  if (mode.filter < 0 || mode.filter > 3)
    throw ValueError(o + ": filter " + std::to_string(mode.filter) + " is not 0..3");
  if (mode.wrap < 0 || mode.wrap > 3) throw ValueError(o + ": wrap " + std::to_string(mode.wrap) + " is not 0..3");
  tex.floating();
  if (mode.cube) {
    tex.rank({5}).shape({-1, 6, -1, -1, -1}, "[minibatch_size, 6, size, size, channels]");
    if (tex.size(2) != tex.size(3))
      throw ValueError(o + ": the cube map 'tex' " + shape_string(tex.shape()) + " has faces that are not square");
  } else {
    tex.rank({4});
  }
  for (std::int64_t s : tex.shape())
    if (s < 1) throw ValueError(o + ": 'tex' " + shape_string(tex.shape()) + " has a size below 1");
  if (tex.size(-3) > kMaxTextureSide || tex.size(-2) > kMaxTextureSide)
    throw ValueError(o + ": 'tex' sides must be at most " + std::to_string(kMaxTextureSide) + ", got " +
                     shape_string(tex.shape()));
  tex_images = tex.size(0);
  height = static_cast<int>(tex.size(-3));
  width = static_cast<int>(tex.size(-2));
  channels = tex.size(-1);
  const int chain = raster::mip_layout(height, width, -1).count();
  if (mode.levels < 1 || mode.levels > chain)
    throw ValueError(o + ": " + std::to_string(mode.levels) + " mip levels; a " + std::to_string(height) + " x " +
                     std::to_string(width) + " texture has 1.." + std::to_string(chain));
  if (mode.user && (mode.cube || mode.levels < 2))
    throw ValueError(o + ": a user mip stack needs a 2D texture and at least 2 levels");
  layout = raster::mip_layout(height, width, mode.levels - 1);
  if (mode.device_levels && (mode.user || mode.levels < 2 || pyramid || !lookups))
    throw ValueError(o + ": levels built on the device are for lookups with 2 or more levels, not the user's, and "
                     "no 'pyramid'");
  if (mode.levels > 1 && !mode.device_levels) pyramid.required("the mip stack of levels 1..");
  if (mode.levels == 1 && pyramid) throw ValueError(o + ": 'pyramid' is given for one mip level");
  pyramid.same_elem(tex).shape({tex_images, pyramid_values() / channels, channels});
  if (!lookups) {
    for (const Array* a : {&uv, &uv_dx, &uv_dy, &bias, &uv_jacobian})
      if (*a) throw ValueError(o + ": '" + a->name() + "' is given without lookups");
    return;
  }
  uv.same_elem(tex).rank({4}).shape({-1, -1, -1, mode.cube ? 3 : 2});
  images = uv.size(0);
  samples = uv.size(1) * uv.size(2);
  if (tex_images != 1 && tex_images != images)
    throw ValueError(o + ": 'tex' has minibatch size " + std::to_string(tex_images) + " but 'uv' has " +
                     std::to_string(images) + " (broadcast needs 1)");
  const std::int64_t B = images, h = uv.size(1), w = uv.size(2);
  uv_dx.same_elem(tex).shape({B, h, w, mode.cube ? 6 : 2});
  if (mode.cube && uv_dy) throw ValueError(o + ": 'uv_dy' is given for a cube map (its uv_da is 'uv_dx')");
  uv_dy.same_elem(tex).shape({B, h, w, 2});
  bias.same_elem(tex).shape({B, h, w});
  if (uv_jacobian && (mode.cube || mode.filter != 1))
    throw ValueError(o + ": 'uv_jacobian' is kept for the bilinear filter of a 2D texture only");
  uv_jacobian.same_elem(tex).shape({B, h, w, 2, channels});
}

namespace {

// raster::Filter -> raster::CubeFilter.
raster::CubeFilter cube_filter(int filter) {
  switch (static_cast<raster::Filter>(filter)) {
    case raster::Filter::Nearest: return raster::CubeFilter::Nearest;
    case raster::Filter::Bilinear: return raster::CubeFilter::Bilinear;
    case raster::Filter::Trilinear: return raster::CubeFilter::Trilinear;
    case raster::Filter::LinearMipmapNearest: return raster::CubeFilter::LinearMipmapNearest;
  }
  return raster::CubeFilter::Bilinear;
}

template <class T>
raster::CubeTextureParams<T> cube_params(const TextureArgs& a, std::int64_t b) {
  const std::int64_t t = a.tex_images == 1 ? 0 : b;
  raster::CubeTextureParams<T> p;
  p.faces = a.tex.in<T>() + t * a.texture_values();
  if (a.pyramid) p.pyramid = a.pyramid.in<T>() + t * a.pyramid_values();
  p.layout = a.layout;
  p.channels = a.channels;
  p.dir = a.uv.in<T>() + 3 * a.samples * b;
  if (a.uv_dx) p.dir_da = a.uv_dx.in<T>() + 6 * a.samples * b;
  if (a.bias) p.mip_level_bias = a.bias.in<T>() + a.samples * b;
  p.num_samples = a.samples;
  p.filter = cube_filter(a.mode.filter);
  return p;
}

template <class T>
raster::TextureParams<T> image_params(const TextureArgs& a, std::int64_t b) {
  const std::int64_t t = a.tex_images == 1 ? 0 : b;
  raster::TextureParams<T> p;
  p.tex = a.tex.in<T>() + t * a.texture_values();
  if (a.pyramid) p.pyramid = a.pyramid.in<T>() + t * a.pyramid_values();
  p.user_pyramid = a.mode.user;
  p.layout = a.layout;
  p.channels = a.channels;
  p.uv = a.uv.in<T>() + 2 * a.samples * b;
  if (a.uv_dx) p.uv_dx = a.uv_dx.in<T>() + 2 * a.samples * b;
  if (a.uv_dy) p.uv_dy = a.uv_dy.in<T>() + 2 * a.samples * b;
  if (a.bias) p.mip_level_bias = a.bias.in<T>() + a.samples * b;
  p.num_samples = a.samples;
  p.filter = static_cast<raster::Filter>(a.mode.filter);
  p.wrap = static_cast<raster::Wrap>(a.mode.wrap);
  p.v_down = true;                            // nvdiffrast's texel rows
  p.lod_rule = raster::LodRule::MajorAxis;  // and its level of detail
  return p;
}

// The backend that runs a's lookups (ctx's, for float32; null: the CPU
// kernels). Its adjoint reads the texels, so no uv Jacobian is kept for it.
const raster::RasterBackend* lookups_backend(const Context* ctx, const TextureArgs& a, const char* op) {
  const raster::RasterBackend* backend = a.f64() ? nullptr : backend_for<float>(ctx);
  if (backend && a.uv_jacobian)
    throw ValueError(std::string(op) + ": 'uv_jacobian' is for the CPU kernels; the device's lookups keep none");
  if (a.mode.device_levels && !(backend && backend->builds_mip_levels()))
    throw ValueError(std::string(op) + ": no 'pyramid' (mode.device_levels) needs float32 lookups on a device "
                     "that builds the mip levels");
  return backend;
}

// The forward's handle of texture image t (texture_forward), when it kept one; else null.
std::shared_ptr<const raster::DeviceTexture> handle_of(const std::shared_ptr<DeviceTextures>& kept, std::int64_t t) {
  if (kept && static_cast<std::size_t>(t) < kept->images.size()) return kept->images[static_cast<std::size_t>(t)];
  return nullptr;
}

// Image b's part of the saved uv Jacobian, or null.
template <class T>
T* jacobian(const TextureArgs& a, std::int64_t b) {
  return a.uv_jacobian ? a.uv_jacobian.out<T>() + b * a.samples * 2 * a.channels : nullptr;
}

}  // namespace

std::vector<std::pair<int, int>> mip_sizes(int height, int width, int max_level) {
  if (height < 1 || width < 1 || height > kMaxTextureSide || width > kMaxTextureSide)
    throw ValueError("mip_sizes: a " + std::to_string(height) + " x " + std::to_string(width) +
                     " texture is outside 1.." + std::to_string(kMaxTextureSide) + " per side");
  std::vector<std::pair<int, int>> sizes;
  for (const raster::MipLevel& l : raster::mip_layout(height, width, max_level).levels)
    sizes.emplace_back(l.height, l.width);
  return sizes;
}

void mip_build(const TextureMode& mode, Objects tex, Objects pyramid, int threads) {
  const TextureArgs a(mode, tex, pybind11::none(), pybind11::none(), pybind11::none(), pybind11::none(), pyramid,
                      pybind11::none(), "texture_construct_mip", false);
  a.pyramid.required("levels 1.. are written there");
  check_disjoint("texture_construct_mip", {&a.pyramid}, {&a.tex});
  KernelCall call(threads);
  dispatch(a.f64(), [&](auto tag) {
    using T = decltype(tag);
    for (std::int64_t t = 0; t < a.tex_images; ++t) {
      const T* base = a.tex.in<T>() + t * a.texture_values();
      T* levels = a.pyramid.out<T>() + t * a.pyramid_values();
      if (a.mode.cube)
        raster::cube_mip_build(base, a.channels, a.layout, levels);
      else
        raster::mip_build(base, a.channels, a.layout, levels);
    }
  });
}

std::shared_ptr<DeviceTextures> texture_forward(Context* ctx, const TextureMode& mode, Objects tex, Objects uv,
                                                Objects uv_dx, Objects uv_dy, Objects bias, Objects pyramid,
                                                Objects out_, Objects uv_jacobian, int threads,
                                                const std::shared_ptr<DeviceTextures>& kept_before) {
  const char* op = "texture";
  const TextureArgs a(mode, tex, uv, uv_dx, uv_dy, bias, pyramid, uv_jacobian, op, true);
  const Array out(out_, op, "out");
  out.same_elem(a.tex).shape({a.images, a.uv.size(1), a.uv.size(2), a.channels});
  check_disjoint(op, {&out, &a.uv_jacobian}, {&a.tex, &a.pyramid, &a.uv, &a.uv_dx, &a.uv_dy, &a.bias});
  const raster::RasterBackend* backend = lookups_backend(ctx, a, op);
  // No samples (an image of no rows or columns): nothing to look up, and the
  // kernels would take its empty uv_dx, uv_dy (null data) for absent ones.
  if (a.samples == 0) return kept_before;
  // On a device: one handle per texture image, for the backward and later
  // calls (a device runs the images in order); an earlier call's to start from.
  std::shared_ptr<DeviceTextures> kept;
  if (backend) {
    kept = std::make_shared<DeviceTextures>();
    if (kept_before && static_cast<std::int64_t>(kept_before->images.size()) != a.tex_images)
      throw ValueError(std::string(op) + ": 'kept' holds " + std::to_string(kept_before->images.size()) +
                       " texture images, 'tex' has " + std::to_string(a.tex_images));
    if (kept_before) kept->images = kept_before->images;
    kept->images.resize(static_cast<std::size_t>(a.tex_images));
  }
  KernelCall call(threads);
  dispatch(a.f64(), [&](auto tag) {
    using T = decltype(tag);
    for_each_image_on(backend, a.images, [&](std::int64_t b) {
      T* o = out.out<T>() + b * a.samples * a.channels;
      if constexpr (std::is_same_v<T, float>)
        if (backend) {
          auto& handle = kept->images[a.tex_images == 1 ? 0 : b];
          if (counted(*ctx, a.mode.cube ? backend->cube_texture_forward(cube_params<T>(a, b), o, handle)
                                        : backend->texture_forward(image_params<T>(a, b), o, handle)))
            return;
        }
      if (a.mode.cube)
        raster::cube_texture_forward(cube_params<T>(a, b), o);
      else
        raster::texture_forward(image_params<T>(a, b), o, jacobian<T>(a, b));
    });
  });
  if (kept)
    for (const auto& h : kept->images)
      if (h) return kept;
  return nullptr;
}

void texture_backward(Context* ctx, const TextureMode& mode, Objects tex, Objects uv, Objects uv_dx, Objects uv_dy,
                      Objects bias, Objects pyramid, Objects uv_jacobian, Objects grad_out_, Objects grad_tex_,
                      Objects grad_uv_, Objects grad_uv_dx_, Objects grad_uv_dy_, Objects grad_bias_,
                      Objects grad_pyramid_, int threads, const std::shared_ptr<DeviceTextures>& kept) {
  const char* op = "texture backward";
  const TextureArgs a(mode, tex, uv, uv_dx, uv_dy, bias, pyramid, uv_jacobian, op, true);
  const Array grad_out(grad_out_, op, "grad_out"), grad_tex(grad_tex_, op, "grad_tex", true),
      grad_uv(grad_uv_, op, "grad_uv", true), grad_uv_dx(grad_uv_dx_, op, "grad_uv_dx", true),
      grad_uv_dy(grad_uv_dy_, op, "grad_uv_dy", true), grad_bias(grad_bias_, op, "grad_bias", true),
      grad_pyramid(grad_pyramid_, op, "grad_pyramid", true);
  grad_out.same_elem(a.tex).shape({a.images, a.uv.size(1), a.uv.size(2), a.channels});
  // Each gradient is shaped like its input, which must be there.
  const std::pair<const Array*, const Array*> grads[] = {{&grad_tex, &a.tex},       {&grad_uv, &a.uv},
                                                         {&grad_uv_dx, &a.uv_dx},   {&grad_uv_dy, &a.uv_dy},
                                                         {&grad_bias, &a.bias},     {&grad_pyramid, &a.pyramid}};
  for (const auto& [g, input] : grads) {
    if (*g && !*input)
      throw ValueError(std::string(op) + ": '" + g->name() + "' is given but '" + input->name() + "' is not");
    g->same_elem(a.tex).shape(input->shape());
  }
  if (grad_pyramid && !a.mode.user)
    throw ValueError(std::string(op) + ": 'grad_pyramid' is for a user mip stack only");
  check_disjoint(op, {&grad_tex, &grad_uv, &grad_uv_dx, &grad_uv_dy, &grad_bias, &grad_pyramid},
                 {&a.tex, &a.pyramid, &a.uv, &a.uv_dx, &a.uv_dy, &a.bias, &a.uv_jacobian, &grad_out});
  const raster::RasterBackend* backend = lookups_backend(ctx, a, op);
  if (a.samples == 0) return;  // no samples: every gradient stays zero (as texture_forward)
  KernelCall call(threads);
  dispatch(a.f64(), [&](auto tag) {
    using T = decltype(tag);
    // The texel addresses come from these (the forward checks them too).
    raster::detail::check_finite(a.uv.in<T>(), a.uv.numel(), "uv", op);
    if (a.uv_dx) raster::detail::check_finite(a.uv_dx.in<T>(), a.uv_dx.numel(), a.uv_dx.name().c_str(), op);
    if (a.uv_dy) raster::detail::check_finite(a.uv_dy.in<T>(), a.uv_dy.numel(), "uv_dy", op);
    if (a.bias) raster::detail::check_finite(a.bias.in<T>(), a.bias.numel(), "mip_level_bias", op);
    auto image = [&](std::int64_t b) {
      const std::int64_t t = a.tex_images == 1 ? 0 : b;
      const T* g_out = grad_out.in<T>() + b * a.samples * a.channels;
      if (a.mode.cube) {
        raster::CubeTextureGrads<T> g;
        if (grad_tex) g.faces = grad_tex.out<T>() + t * a.texture_values();
        if (grad_uv) g.dir = grad_uv.out<T>() + 3 * a.samples * b;
        if (grad_uv_dx) g.dir_da = grad_uv_dx.out<T>() + 6 * a.samples * b;  // the cube's uv_da gradient
        if (grad_bias) g.mip_level_bias = grad_bias.out<T>() + a.samples * b;
        if constexpr (std::is_same_v<T, float>)
          if (backend) {
            std::shared_ptr<const raster::DeviceTexture> handle = handle_of(kept, t);
            // No handle: the plain call (a null handle would keep a new copy nobody finds again).
            if (counted(*ctx, handle ? backend->cube_texture_backward(cube_params<T>(a, b), g_out, g, handle)
                                     : backend->cube_texture_backward(cube_params<T>(a, b), g_out, g)))
              return;
          }
        raster::cube_texture_backward(cube_params<T>(a, b), g_out, g);
        return;
      }
      raster::TextureGrads<T> g;
      if (grad_tex) g.tex = grad_tex.out<T>() + t * a.texture_values();
      if (grad_uv) g.uv = grad_uv.out<T>() + 2 * a.samples * b;
      if (grad_uv_dx) g.uv_dx = grad_uv_dx.out<T>() + 2 * a.samples * b;
      if (grad_uv_dy) g.uv_dy = grad_uv_dy.out<T>() + 2 * a.samples * b;
      if (grad_bias) g.mip_level_bias = grad_bias.out<T>() + a.samples * b;
      if (grad_pyramid) g.pyramid = grad_pyramid.out<T>() + t * a.pyramid_values();
      if constexpr (std::is_same_v<T, float>)
        if (backend) {
          std::shared_ptr<const raster::DeviceTexture> handle = handle_of(kept, t);
          if (counted(*ctx, handle ? backend->texture_backward(image_params<T>(a, b), g_out, g, handle)
                                   : backend->texture_backward(image_params<T>(a, b), g_out, g)))
            return;
        }
      raster::texture_backward(image_params<T>(a, b), g_out, g, jacobian<T>(a, b));
    };
    // A broadcast texture collects every image's gradient, and a device runs
    // one call at a time: images in order (each lookup parallel inside);
    // otherwise images in parallel.
    if (a.tex_images == 1 && (grad_tex || grad_pyramid))
      for (std::int64_t b = 0; b < a.images; ++b) image(b);
    else
      for_each_image_on(backend, a.images, image);
  });
}

}  // namespace gr::python
