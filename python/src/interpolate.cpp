#include "python/src/interpolate.h"

#include <string>
#include <type_traits>

#include "autodiff/base/error.h"
#include "python/src/backend.h"
#include "raster/barycentric_interpolate.h"
#include "raster/mesh_checks.h"

namespace gr::python {
namespace {

template <class T>
raster::BarycentricInterpolateParams<T> image_params(const InterpolateArgs& a, std::int64_t b) {
  const std::int64_t pixels = a.height * a.width;
  raster::BarycentricInterpolateParams<T> p;
  p.attr = a.attr.in<T>() + (a.attr_images == 1 ? 0 : b * a.vertices * a.channels);
  p.num_vertices = a.vertices;
  p.channels = a.channels;
  p.tris = a.tri.in<std::int32_t>();
  p.num_tris = a.triangles;
  p.rast = a.rast.in<T>() + 4 * pixels * b;
  p.pixels = pixels;
  if (a.rast_db && !a.diff.empty()) {
    p.rast_db = a.rast_db.in<T>() + 4 * pixels * b;
    p.diff = a.diff.data();
    p.num_diff = static_cast<std::int64_t>(a.diff.size());
  }
  return p;
}

// What image b's call hands the backend: p with its coverage as int32 ids
// (kept in s), as kept's copy drew the image (a range's triangles, ids
// local to it) with that copy, or p's with none (raster::image_on_device);
// call(on.device, q) runs it.
template <class Call>
bool on_backend(const DeviceGBuffers* kept, std::int64_t b, raster::BarycentricInterpolateParams<float> p,
                ImageScratch& s, const Call& call) {
  rast_ids(p.rast, p.pixels, &s.tri_id);
  const raster::ImageOnDevice on = image_on_device(kept, b, p.tris, p.num_tris, s.tri_id.data(), p.pixels, false);
  p.tris = on.tris;
  p.num_tris = on.num_tris;
  p.tri_id = on.ids();
  return call(on.device, p);
}

// The values the kernels index with: tri's indices, rast's ids.
template <class T>
void check_values(const InterpolateArgs& a, const char* op) {
  raster::detail::check_triangles(a.tri.in<std::int32_t>(), a.triangles, a.vertices, op);
  raster::detail::check_rast_ids(a.rast.in<T>(), a.images * a.height * a.width, a.triangles, "rast", op);
}

}  // namespace

InterpolateArgs::InterpolateArgs(const pybind11::object& attr_, const pybind11::object& rast_,
                                 const pybind11::object& tri_, const pybind11::object& rast_db_,
                                 std::vector<std::int32_t> diff_, const char* op)
    : attr(attr_, op, "attr"), rast(rast_, op, "rast"), tri(tri_, op, "tri"), rast_db(rast_db_, op, "rast_db", true),
      diff(std::move(diff_)) {
  rast.floating();
  check_rast_shape(rast, -1, rast.elem(), op);
  attr.same_elem(rast).rank({2, 3});
  tri.elem_in({Elem::I32}).rank({2}).shape({-1, 3}, "[num_triangles, 3]");
  images = rast.size(0);
  height = rast.size(1);
  width = rast.size(2);
  attr_images = attr.dim() == 3 ? attr.size(0) : 1;
  if (attr_images != 1 && attr_images != images)
    throw ValueError(std::string(op) + ": 'attr' has minibatch size " + std::to_string(attr_images) +
                     " but 'rast' has " + std::to_string(images) + " (broadcast needs 1)");
  vertices = attr.size(-2);
  channels = attr.size(-1);
  triangles = tri.size(0);
  rast_db.same_elem(rast).shape(rast.shape());
  for (std::int32_t d : diff)
    if (d < 0 || d >= channels)
      throw ValueError(std::string(op) + ": 'diff_attrs' index " + std::to_string(d) + " is outside 0.." +
                       std::to_string(channels - 1) + " (attr has " + std::to_string(channels) + " attributes)");
  if (!diff.empty()) rast_db.required("'diff_attrs' needs it (the second output of rasterize)");
}

std::shared_ptr<InterpolateKept> interpolate_forward(Context* ctx, const pybind11::object& attr,
                                                     const pybind11::object& rast, const pybind11::object& tri,
                                                     const pybind11::object& rast_db, std::vector<std::int32_t> diff,
                                                     const pybind11::object& out_, const pybind11::object& out_da_,
                                                     int threads, const DeviceGBuffers* kept) {
  const char* op = "interpolate";
  const InterpolateArgs a(attr, rast, tri, rast_db, std::move(diff), op);
  const std::int64_t K = static_cast<std::int64_t>(a.diff.size());
  const Array out(out_, op, "out"), out_da(out_da_, op, "out_da", true);
  out.same_elem(a.rast).shape({a.images, a.height, a.width, a.channels});
  if (K) out_da.required("the derivatives of 'diff_attrs' go there");
  if (!K && out_da) throw ValueError(std::string(op) + ": 'out_da' is given but 'diff_attrs' is empty");
  out_da.same_elem(a.rast).shape({a.images, a.height, a.width, 2 * K});
  check_disjoint(op, {&out, &out_da}, {&a.attr, &a.rast, &a.tri, &a.rast_db});
  check_kept(kept, a.images, op);
  KernelCall call(threads);
  const std::int64_t pixels = a.height * a.width;
  std::shared_ptr<InterpolateKept> left;  // what the device kept for the adjoint
  dispatch(a.rast.elem() == Elem::F64, [&](auto tag) {
    using T = decltype(tag);
    check_values<T>(a, op);
    const raster::RasterBackend* backend = backend_for<T>(ctx);
    if (backend) {
      ctx->reserve(a.images);
      left = std::make_shared<InterpolateKept>();
      left->images.resize(static_cast<std::size_t>(a.images));
    }
    for_each_image_on(backend, a.images, [&](std::int64_t b) {
      raster::BarycentricInterpolateParams<T> p = image_params<T>(a, b);
      T* o = out.out<T>() + b * pixels * a.channels;
      T* o_da = out_da ? out_da.out<T>() + b * pixels * 2 * K : nullptr;
      if constexpr (std::is_same_v<T, float>)
        if (backend) {
          const int w = int(a.width), h = int(a.height);
          const bool ran = on_backend(kept, b, p, ctx->image(b), [&](const raster::DeviceGBuffer* on, const auto& q) {
            return backend->interpolate_forward(on, q, w, h, o, o_da, &left->images[b]);
          });
          if (counted(*ctx, ran)) return;
        }
      raster::barycentric_interpolate_forward(p, o, o_da);
    });
  });
  return left;
}

void interpolate_backward(Context* ctx, const pybind11::object& attr, const pybind11::object& rast,
                          const pybind11::object& tri, const pybind11::object& rast_db, std::vector<std::int32_t> diff,
                          const pybind11::object& grad_out_, const pybind11::object& grad_da_,
                          const pybind11::object& grad_attr_, const pybind11::object& grad_rast_,
                          const pybind11::object& grad_db_, int threads, const DeviceGBuffers* kept,
                          const InterpolateKept* forward) {
  const char* op = "interpolate backward";
  const InterpolateArgs a(attr, rast, tri, rast_db, std::move(diff), op);
  const std::int64_t K = static_cast<std::int64_t>(a.diff.size());
  const Array grad_out(grad_out_, op, "grad_out"), grad_da(grad_da_, op, "grad_da", true),
      grad_attr(grad_attr_, op, "grad_attr", true), grad_rast(grad_rast_, op, "grad_rast", true),
      grad_db(grad_db_, op, "grad_db", true);
  grad_out.same_elem(a.rast).shape({a.images, a.height, a.width, a.channels});
  if (!K && grad_da) throw ValueError(std::string(op) + ": 'grad_da' is given but 'diff_attrs' is empty");
  grad_da.same_elem(a.rast).shape({a.images, a.height, a.width, 2 * K});
  grad_attr.same_elem(a.rast).shape(a.attr.shape());
  grad_rast.same_elem(a.rast).shape(a.rast.shape());
  if (grad_db && !a.rast_db) throw ValueError(std::string(op) + ": 'grad_db' is given but 'rast_db' is not");
  grad_db.same_elem(a.rast).shape(a.rast.shape());
  check_disjoint(op, {&grad_attr, &grad_rast, &grad_db}, {&a.attr, &a.rast, &a.tri, &a.rast_db, &grad_out, &grad_da});
  check_kept(kept, a.images, op);
  if (forward && static_cast<std::int64_t>(forward->images.size()) != a.images)
    throw ValueError(std::string(op) + ": 'forward' is of a call with " + std::to_string(forward->images.size()) +
                     " images; these inputs have " + std::to_string(a.images));
  auto from_forward = [forward](std::int64_t b) {
    return forward ? forward->images[static_cast<std::size_t>(b)].get() : nullptr;
  };
  KernelCall call(threads);
  const std::int64_t pixels = a.height * a.width;
  dispatch(a.rast.elem() == Elem::F64, [&](auto tag) {
    using T = decltype(tag);
    check_values<T>(a, op);
    // A broadcast attr's gradient: one buffer per image, summed in image order.
    const bool shared = grad_attr && a.attr_images == 1 && a.images > 1;
    const std::int64_t attr_values = a.vertices * a.channels;
    std::vector<std::vector<T>> parts(shared ? static_cast<std::size_t>(a.images) : 0);
    const raster::RasterBackend* backend = backend_for<T>(ctx);
    if (backend) ctx->reserve(a.images);
    for_each_image_on(backend, a.images, [&](std::int64_t b) {
      raster::BarycentricInterpolateGrads<T> g;
      if (shared) {
        parts[b].assign(static_cast<std::size_t>(attr_values), T(0));
        g.attr = parts[b].data();
      } else if (grad_attr) {
        g.attr = grad_attr.out<T>() + (a.attr_images == 1 ? 0 : b * attr_values);
      }
      if (grad_rast) g.rast = grad_rast.out<T>() + 4 * pixels * b;
      if (grad_db) g.rast_db = grad_db.out<T>() + 4 * pixels * b;
      const raster::BarycentricInterpolateParams<T> p = image_params<T>(a, b);
      const T* g_out = grad_out.in<T>() + b * pixels * a.channels;
      const T* g_da = grad_da ? grad_da.in<T>() + b * pixels * 2 * K : nullptr;
      if constexpr (std::is_same_v<T, float>)
        if (backend) {
          const int w = int(a.width), h = int(a.height);
          const bool ran = on_backend(kept, b, p, ctx->image(b), [&](const raster::DeviceGBuffer* on, const auto& q) {
            return backend->interpolate_backward(on, q, w, h, g_out, g_da, g, from_forward(b));
          });
          if (counted(*ctx, ran)) return;
        }
      raster::barycentric_interpolate_backward(p, g_out, g_da, g);
    });
    if (shared) {
      std::vector<const T*> order;
      for (const std::vector<T>& part : parts) order.push_back(part.data());
      raster::sum_in_image_order(order.data(), a.images, attr_values, grad_attr.out<T>());
    }
  });
}

}  // namespace gr::python
