#include "python/src/common.h"

#include <atomic>
#include <cmath>
#include <cstdint>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/detail/rasterize_setup.h"

namespace gr::python {
namespace {
std::mutex g_kernel_mutex;
int g_threads = -1;  // the last count given to set_num_threads
}  // namespace

KernelCall::KernelCall(int threads) : lock_(g_kernel_mutex) {
  if (threads != g_threads) {
    set_num_threads(threads);
    g_threads = threads;
  }
}

void for_each_image(std::int64_t images, const std::function<void(std::int64_t)>& body) {
  parallel_for(0, images, 1, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t b = lo; b < hi; ++b) body(b);
  });
}

template <class T>
void add_in_image_order(const std::vector<std::vector<T>*>& parts, std::int64_t n, T* out) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (const std::vector<T>* part : parts)
      for (std::int64_t i = lo; i < hi; ++i) out[i] += (*part)[i];
  });
}
template void add_in_image_order<float>(const std::vector<std::vector<float>*>&, std::int64_t, float*);
template void add_in_image_order<double>(const std::vector<std::vector<double>*>&, std::int64_t, double*);

Mesh::Mesh(const pybind11::handle& pos_, const pybind11::handle& tri_, Ranges ranges_, const char* op)
    : pos(pos_, op, "pos"), tri(tri_, op, "tri"), ranges(std::move(ranges_)) {
  pos.floating().rank({2, 3}).shape(pos.dim() == 3 ? std::vector<std::int64_t>{-1, -1, 4}
                                                   : std::vector<std::int64_t>{-1, 4},
                                    "[..., num_vertices, 4]");
  tri.elem_in({Elem::I32}).rank({2}).shape({-1, 3}, "[num_triangles, 3]");
  f64 = pos.elem() == Elem::F64;
  instanced = pos.dim() == 3;
  vertices = pos.size(-2);
  triangles = tri.size(0);
  if (instanced) {
    images = pos.size(0);
    if (images < 1)
      throw ValueError(std::string(op) + ": instanced mode - 'pos' must have shape [>0, num_vertices, 4], got " +
                       shape_string(pos.shape()));
    if (!ranges.empty())
      throw ValueError(std::string(op) + ": 'ranges' is for range mode ('pos' [num_vertices, 4]); 'pos' is " +
                       shape_string(pos.shape()));
  } else {
    images = static_cast<std::int64_t>(ranges.size());
    if (images < 1)
      throw ValueError(std::string(op) + ": range mode - 'pos' is [num_vertices, 4], so 'ranges' [minibatch_size, 2] "
                       "is required");
  }
  if (!f64 && triangles >= kMaxFloat32Ids)
    throw ValueError(std::string(op) + ": " + std::to_string(triangles) + " triangles are more than float32 rast "
                     "can number exactly (" + std::to_string(kMaxFloat32Ids - 1) + "); use float64");
}

void check_rast_shape(const Array& rast, std::int64_t images, Elem elem, const char* op) {
  rast.required().elem_in({Elem::F32, Elem::F64}).rank({4}).shape({images, -1, -1, 4},
                                                                  "[minibatch_size, height, width, 4]");
  if (rast.elem() != elem)
    throw DTypeError(std::string(op) + ": '" + rast.name() + "' has dtype " + elem_name(rast.elem()) +
                     " but the positions or attributes have " + elem_name(elem) + "; use one float dtype");
  if (rast.size(1) > INT32_MAX || rast.size(2) > INT32_MAX)
    throw ValueError(std::string(op) + ": '" + rast.name() + "' " + shape_string(rast.shape()) + " is too large");
}

void check_mesh(const Mesh& mesh, const char* op) {
  const std::int64_t values = 4 * mesh.vertices * (mesh.instanced ? mesh.images : 1);
  if (mesh.f64)
    raster::detail::check_finite(mesh.pos.in<double>(), values, "pos", op);
  else
    raster::detail::check_finite(mesh.pos.in<float>(), values, "pos", op);
  raster::detail::check_triangles(mesh.tris(), mesh.triangles, mesh.vertices, op);
  for (std::size_t b = 0; b < mesh.ranges.size(); ++b) {
    const auto [first, count] = mesh.ranges[b];
    if (first < 0 || count < 0 || first > mesh.triangles || count > mesh.triangles - first)
      throw IndexError(std::string(op) + ": ranges[" + std::to_string(b) + "] = (" + std::to_string(first) + ", " +
                       std::to_string(count) + ") is outside the " + std::to_string(mesh.triangles) +
                       " triangles of 'tri'");
  }
}

template <class T>
void check_rast_ids(const T* rast, std::int64_t pixels, std::int64_t triangles, const char* what, const char* op) {
  // A branch-free pass over the ids (vectorized, in parallel) says whether
  // any is bad; only then the pass below finds the first.
  const T top = static_cast<T>(triangles);
  std::atomic<bool> bad{false};
  parallel_for(0, pixels, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    bool ok = true;
    for (std::int64_t q = lo; q < hi; ++q) {
      const T id = rast[4 * q + 3];
      ok &= (id >= 0) & (id <= top) & (id == std::floor(id));
    }
    if (!ok) bad.store(true, std::memory_order_relaxed);
  });
  if (!bad.load()) return;
  for (std::int64_t q = 0; q < pixels; ++q) {
    const T id = rast[4 * q + 3];
    if (!(id >= 0 && id <= static_cast<T>(triangles) && id == std::floor(id)))
      throw IndexError(std::string(op) + ": " + what + "[..., 3] (triangle id + 1) at pixel " + std::to_string(q) +
                       " is " + std::to_string(id) + ", not an integer in [0, " + std::to_string(triangles) +
                       "] (the triangle count of 'tri')");
  }
}

template void check_rast_ids<float>(const float*, std::int64_t, std::int64_t, const char*, const char*);
template void check_rast_ids<double>(const double*, std::int64_t, std::int64_t, const char*, const char*);

}  // namespace gr::python
