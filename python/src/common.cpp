#include "python/src/common.h"

#include <cstdint>
#include <string>
#include <utility>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/mesh_checks.h"

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

Mesh::Mesh(const pybind11::handle& pos_, const pybind11::handle& tri_, const Ranges& ranges, const char* op)
    : pos(pos_, op, "pos"), tri(tri_, op, "tri") {
  pos.floating().rank({2, 3}).shape(pos.dim() == 3 ? std::vector<std::int64_t>{-1, -1, 4}
                                                   : std::vector<std::int64_t>{-1, 4},
                                    "[..., num_vertices, 4]");
  tri.elem_in({Elem::I32}).rank({2}).shape({-1, 3}, "[num_triangles, 3]");
  f64 = pos.elem() == Elem::F64;
  raster::ImageBatch& batch = *this;
  if (pos.dim() == 3) {
    if (pos.size(0) < 1)
      throw ValueError(std::string(op) + ": instanced mode - 'pos' must have shape [>0, num_vertices, 4], got " +
                       shape_string(pos.shape()));
    if (!ranges.empty())
      throw ValueError(std::string(op) + ": 'ranges' is for range mode ('pos' [num_vertices, 4]); 'pos' is " +
                       shape_string(pos.shape()));
    batch = raster::ImageBatch::instanced_mode(pos.size(0), pos.size(-2), tri.size(0));
  } else {
    if (ranges.empty())
      throw ValueError(std::string(op) + ": range mode - 'pos' is [num_vertices, 4], so 'ranges' [minibatch_size, 2] "
                       "is required");
    std::vector<raster::ImageBatch::Range> r;
    for (const auto& [first, count] : ranges) r.push_back({first, count});
    batch = raster::ImageBatch::range_mode(std::move(r), pos.size(-2), tri.size(0), op, "tri");
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
}

}  // namespace gr::python
