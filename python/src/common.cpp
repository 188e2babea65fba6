#include "python/src/common.h"

#include <cmath>
#include <string>

#include "autodiff/error.h"
#include "autodiff/parallel.h"
#include "raster/rasterize_setup.h"

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

void check_mesh(const Mesh& mesh, const char* op) {
  const std::int64_t values = 4 * mesh.vertices * (mesh.instanced ? mesh.images : 1);
  if (mesh.f64)
    raster::detail::check_finite(at<const double>(mesh.pos), values, "pos", op);
  else
    raster::detail::check_finite(at<const float>(mesh.pos), values, "pos", op);
  raster::detail::check_triangles(at<const std::int32_t>(mesh.tri), mesh.triangles, mesh.vertices, op);
  for (std::size_t b = 0; b < mesh.ranges.size(); ++b) {
    const auto [first, count] = mesh.ranges[b];
    if (first < 0 || count < 0 || first > mesh.triangles || count > mesh.triangles - first)
      throw IndexError(std::string(op) + ": ranges[" + std::to_string(b) + "] = (" + std::to_string(first) + ", " +
                       std::to_string(count) + ") is outside the " + std::to_string(mesh.triangles) +
                       " triangles of 'tri'");
  }
}

template <class T>
void copy_flipped(const T* pos, std::int64_t vertices, std::vector<T>* out) {
  out->resize(4 * static_cast<std::size_t>(vertices));
  T* o = out->data();
  parallel_for(0, vertices, kElementwiseGrain / 4, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      o[4 * i] = pos[4 * i];
      o[4 * i + 1] = -pos[4 * i + 1];
      o[4 * i + 2] = pos[4 * i + 2];
      o[4 * i + 3] = pos[4 * i + 3];
    }
  });
}

template <class T>
void add_flipped(const T* grad, std::int64_t vertices, T* grad_pos) {
  parallel_for(0, vertices, kElementwiseGrain / 4, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      grad_pos[4 * i] += grad[4 * i];
      grad_pos[4 * i + 1] -= grad[4 * i + 1];
      grad_pos[4 * i + 2] += grad[4 * i + 2];
      grad_pos[4 * i + 3] += grad[4 * i + 3];
    }
  });
}

template <class T>
void check_rast_ids(const T* rast, std::int64_t pixels, std::int64_t triangles, const char* what, const char* op) {
  for (std::int64_t q = 0; q < pixels; ++q) {
    const T id = rast[4 * q + 3];
    if (!(id >= 0 && id <= static_cast<T>(triangles) && id == std::floor(id)))
      throw IndexError(std::string(op) + ": " + what + "[..., 3] (triangle id + 1) at pixel " + std::to_string(q) +
                       " is " + std::to_string(id) + ", not an integer in [0, " + std::to_string(triangles) +
                       "] (the triangle count of 'tri')");
  }
}

template void copy_flipped<float>(const float*, std::int64_t, std::vector<float>*);
template void copy_flipped<double>(const double*, std::int64_t, std::vector<double>*);
template void add_flipped<float>(const float*, std::int64_t, float*);
template void add_flipped<double>(const double*, std::int64_t, double*);
template void check_rast_ids<float>(const float*, std::int64_t, std::int64_t, const char*, const char*);
template void check_rast_ids<double>(const double*, std::int64_t, std::int64_t, const char*, const char*);

}  // namespace gr::python
