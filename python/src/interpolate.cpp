#include "python/src/interpolate.h"

#include "raster/barycentric_interpolate.h"
#include "raster/rasterize_setup.h"

namespace gr::python {
namespace {

template <class T>
raster::BarycentricInterpolateParams<T> image_params(const InterpolateArgs& a, std::int64_t b) {
  const std::int64_t pixels = a.height * a.width;
  raster::BarycentricInterpolateParams<T> p;
  p.attr = at<const T>(a.attr) + (a.attr_images == 1 ? 0 : b * a.vertices * a.channels);
  p.num_vertices = a.vertices;
  p.channels = a.channels;
  p.tris = at<const std::int32_t>(a.tri);
  p.num_tris = a.triangles;
  p.rast = at<const T>(a.rast) + 4 * pixels * b;
  p.pixels = pixels;
  if (a.rast_db && !a.diff.empty()) {
    p.rast_db = at<const T>(a.rast_db) + 4 * pixels * b;
    p.diff = a.diff.data();
    p.num_diff = static_cast<std::int64_t>(a.diff.size());
  }
  return p;
}

}  // namespace

void interpolate_forward(const InterpolateArgs& a, Address out, Address out_da, int threads) {
  KernelCall call(threads);
  raster::detail::check_triangles(at<const std::int32_t>(a.tri), a.triangles, a.vertices, "interpolate");
  const std::int64_t pixels = a.height * a.width;
  const std::int64_t K = static_cast<std::int64_t>(a.diff.size());
  dispatch(a.f64, [&](auto tag) {
    using T = decltype(tag);
    check_rast_ids(at<const T>(a.rast), a.images * pixels, a.triangles, "rast", "interpolate");
    for_each_image(a.images, [&](std::int64_t b) {
      raster::barycentric_interpolate_forward(image_params<T>(a, b), at<T>(out) + b * pixels * a.channels,
                                              out_da ? at<T>(out_da) + b * pixels * 2 * K : nullptr);
    });
  });
}

void interpolate_backward(const InterpolateArgs& a, Address grad_out, Address grad_da, Address grad_attr,
                          Address grad_rast, Address grad_db, int threads) {
  KernelCall call(threads);
  const std::int64_t pixels = a.height * a.width;
  const std::int64_t K = static_cast<std::int64_t>(a.diff.size());
  dispatch(a.f64, [&](auto tag) {
    using T = decltype(tag);
    // A broadcast attr's gradient: one buffer per image, summed in image order.
    const bool shared = grad_attr && a.attr_images == 1 && a.images > 1;
    const std::int64_t attr_values = a.vertices * a.channels;
    std::vector<std::vector<T>> parts(shared ? static_cast<std::size_t>(a.images) : 0);
    for_each_image(a.images, [&](std::int64_t b) {
      raster::BarycentricInterpolateGrads<T> g;
      if (shared) {
        parts[b].assign(static_cast<std::size_t>(attr_values), T(0));
        g.attr = parts[b].data();
      } else if (grad_attr) {
        g.attr = at<T>(grad_attr) + (a.attr_images == 1 ? 0 : b * attr_values);
      }
      if (grad_rast) g.rast = at<T>(grad_rast) + 4 * pixels * b;
      if (grad_db && a.rast_db) g.rast_db = at<T>(grad_db) + 4 * pixels * b;
      raster::barycentric_interpolate_backward(image_params<T>(a, b), at<const T>(grad_out) + b * pixels * a.channels,
                                               grad_da ? at<const T>(grad_da) + b * pixels * 2 * K : nullptr, g);
    });
    if (shared) {
      std::vector<std::vector<T>*> order;
      for (auto& part : parts) order.push_back(&part);
      add_in_image_order(order, attr_values, at<T>(grad_attr));
    }
  });
}

}  // namespace gr::python
