#include "python/src/texture.h"

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

template <class T>
raster::TextureParams<T> image_params(const TextureArgs& a, const raster::MipLayout& layout, std::int64_t b) {
  const std::int64_t t = a.tex_images == 1 ? 0 : b;
  raster::TextureParams<T> p;
  p.tex = at<const T>(a.tex) + t * a.height * a.width * a.channels;
  if (a.pyramid) p.pyramid = at<const T>(a.pyramid) + t * upper_texels(layout) * a.channels;
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
    for (std::int64_t t = 0; t < a.tex_images; ++t)
      raster::mip_build(at<const T>(a.tex) + t * a.height * a.width * a.channels, a.channels, layout,
                        at<T>(a.pyramid) + t * upper_texels(layout) * a.channels);
  });
}

void texture_forward(const TextureArgs& a, Address out, int threads) {
  KernelCall call(threads);
  const raster::MipLayout layout = layout_of(a);
  dispatch(a.f64, [&](auto tag) {
    using T = decltype(tag);
    for_each_image(a.images, [&](std::int64_t b) {
      raster::texture_forward(image_params<T>(a, layout, b), at<T>(out) + b * a.samples * a.channels);
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
      raster::TextureGrads<T> g;
      if (grad_tex) g.tex = at<T>(grad_tex) + t * a.height * a.width * a.channels;
      if (grad_uv) g.uv = at<T>(grad_uv) + 2 * a.samples * b;
      if (grad_uv_dx) g.uv_dx = at<T>(grad_uv_dx) + 2 * a.samples * b;
      if (grad_uv_dy) g.uv_dy = at<T>(grad_uv_dy) + 2 * a.samples * b;
      if (grad_bias) g.mip_level_bias = at<T>(grad_bias) + a.samples * b;
      if (grad_pyramid) g.pyramid = at<T>(grad_pyramid) + t * upper_texels(layout) * a.channels;
      raster::texture_backward(image_params<T>(a, layout, b), at<const T>(grad_out) + b * a.samples * a.channels, g);
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
