#include "python/src/texture.h"

#include "raster/cube_texture.h"
#include "raster/mipmap.h"
#include "raster/texture.h"

namespace gr::python {
namespace {

raster::MipLayout layout_of(const TextureArgs& a) {
  return raster::mip_layout(a.height, a.width, a.levels - 1);
}

std::int64_t upper_texels(const raster::MipLayout& layout) {
  return layout.total_texels - static_cast<std::int64_t>(layout.levels[0].height) * layout.levels[0].width;
}

// Values of one texture image: 2D, or 6 faces for a cube map.
std::int64_t texture_values(const TextureArgs& a) { return (a.cube ? 6 : 1) * a.height * a.width * a.channels; }
std::int64_t pyramid_values(const TextureArgs& a, const raster::MipLayout& layout) {
  return (a.cube ? 6 : 1) * upper_texels(layout) * a.channels;
}

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
raster::CubeTextureParams<T> cube_params(const TextureArgs& a, const raster::MipLayout& layout, std::int64_t b) {
  const std::int64_t t = a.tex_images == 1 ? 0 : b;
  raster::CubeTextureParams<T> p;
  p.faces = at<const T>(a.tex) + t * texture_values(a);
  if (a.pyramid) p.pyramid = at<const T>(a.pyramid) + t * pyramid_values(a, layout);
  p.layout = layout;
  p.channels = a.channels;
  p.dir = at<const T>(a.uv) + 3 * a.samples * b;
  if (a.uv_da) p.dir_da = at<const T>(a.uv_da) + 6 * a.samples * b;
  if (a.bias) p.mip_level_bias = at<const T>(a.bias) + a.samples * b;
  p.num_samples = a.samples;
  p.filter = cube_filter(a.filter);
  return p;
}

template <class T>
raster::TextureParams<T> image_params(const TextureArgs& a, const raster::MipLayout& layout, std::int64_t b) {
  const std::int64_t t = a.tex_images == 1 ? 0 : b;
  raster::TextureParams<T> p;
  p.tex = at<const T>(a.tex) + t * texture_values(a);
  if (a.pyramid) p.pyramid = at<const T>(a.pyramid) + t * pyramid_values(a, layout);
  p.user_pyramid = a.user;
  p.layout = layout;
  p.channels = a.channels;
  p.uv = at<const T>(a.uv) + 2 * a.samples * b;
  if (a.uv_dx) p.uv_dx = at<const T>(a.uv_dx) + 2 * a.samples * b;
  if (a.uv_dy) p.uv_dy = at<const T>(a.uv_dy) + 2 * a.samples * b;
  if (a.bias) p.mip_level_bias = at<const T>(a.bias) + a.samples * b;
  p.num_samples = a.samples;
  p.filter = static_cast<raster::Filter>(a.filter);
  p.wrap = static_cast<raster::Wrap>(a.wrap);
  p.v_down = true;                            // nvdiffrast's texel rows
  p.lod_rule = raster::LodRule::MajorAxis;  // and its level of detail
  return p;
}

}  // namespace

std::vector<std::pair<int, int>> mip_sizes(int height, int width, int max_level) {
  std::vector<std::pair<int, int>> sizes;
  for (const raster::MipLevel& l : raster::mip_layout(height, width, max_level).levels)
    sizes.emplace_back(l.height, l.width);
  return sizes;
}

void mip_build(const TextureArgs& a, int threads) {
  KernelCall call(threads);
  const raster::MipLayout layout = layout_of(a);
  dispatch(a.f64, [&](auto tag) {
    using T = decltype(tag);
    for (std::int64_t t = 0; t < a.tex_images; ++t) {
      const T* tex = at<const T>(a.tex) + t * texture_values(a);
      T* pyramid = at<T>(a.pyramid) + t * pyramid_values(a, layout);
      if (a.cube)
        raster::cube_mip_build(tex, a.channels, layout, pyramid);
      else
        raster::mip_build(tex, a.channels, layout, pyramid);
    }
  });
}

// Image b's part of the saved uv Jacobian, or null.
template <class T>
T* jacobian(const TextureArgs& a, std::int64_t b) {
  return a.uv_jacobian ? at<T>(a.uv_jacobian) + b * a.samples * 2 * a.channels : nullptr;
}

void texture_forward(const TextureArgs& a, Address out, int threads) {
  KernelCall call(threads);
  const raster::MipLayout layout = layout_of(a);
  dispatch(a.f64, [&](auto tag) {
    using T = decltype(tag);
    for_each_image(a.images, [&](std::int64_t b) {
      T* o = at<T>(out) + b * a.samples * a.channels;
      if (a.cube)
        raster::cube_texture_forward(cube_params<T>(a, layout, b), o);
      else
        raster::texture_forward(image_params<T>(a, layout, b), o, jacobian<T>(a, b));
    });
  });
}

void texture_backward(const TextureArgs& a, Address grad_out, Address grad_tex, Address grad_uv, Address grad_uv_dx,
                      Address grad_uv_dy, Address grad_bias, Address grad_pyramid, int threads) {
  KernelCall call(threads);
  const raster::MipLayout layout = layout_of(a);
  dispatch(a.f64, [&](auto tag) {
    using T = decltype(tag);
    auto image = [&](std::int64_t b) {
      const std::int64_t t = a.tex_images == 1 ? 0 : b;
      const T* g_out = at<const T>(grad_out) + b * a.samples * a.channels;
      if (a.cube) {
        raster::CubeTextureGrads<T> g;
        if (grad_tex) g.faces = at<T>(grad_tex) + t * texture_values(a);
        if (grad_uv) g.dir = at<T>(grad_uv) + 3 * a.samples * b;
        if (grad_uv_dx) g.dir_da = at<T>(grad_uv_dx) + 6 * a.samples * b;  // the cube's uv_da gradient
        if (grad_bias) g.mip_level_bias = at<T>(grad_bias) + a.samples * b;
        raster::cube_texture_backward(cube_params<T>(a, layout, b), g_out, g);
        return;
      }
      raster::TextureGrads<T> g;
      if (grad_tex) g.tex = at<T>(grad_tex) + t * texture_values(a);
      if (grad_uv) g.uv = at<T>(grad_uv) + 2 * a.samples * b;
      if (grad_uv_dx) g.uv_dx = at<T>(grad_uv_dx) + 2 * a.samples * b;
      if (grad_uv_dy) g.uv_dy = at<T>(grad_uv_dy) + 2 * a.samples * b;
      if (grad_bias) g.mip_level_bias = at<T>(grad_bias) + a.samples * b;
      if (grad_pyramid) g.pyramid = at<T>(grad_pyramid) + t * pyramid_values(a, layout);
      raster::texture_backward(image_params<T>(a, layout, b), g_out, g, jacobian<T>(a, b));
    };
    // A broadcast texture collects every image's gradient: images in order
    // (each lookup parallel inside); otherwise images in parallel.
    if (a.tex_images == 1 && (grad_tex || grad_pyramid))
      for (std::int64_t b = 0; b < a.images; ++b) image(b);
    else
      for_each_image(a.images, image);
  });
}

}  // namespace gr::python
