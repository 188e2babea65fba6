// Shared pieces of the Python binding (gradraster._core). The Python layer
// (python/gradraster/torch/ops.py) passes tensors (detached torch tensors),
// which the functions here take as typed views (python/src/array.h) and
// check themselves: element types, layouts and shapes when the call starts
// (with the GIL), then values (indices, ids, finiteness) inside the kernel
// call. ops.py repeats some checks for nvdiffrast's error messages, but no
// check lives only there. Then they convert nvdiffrast's conventions and run
// the raster/ kernels directly on the tensors' memory.
#pragma once

#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

#include <pybind11/pybind11.h>

#include "python/src/array.h"
#include "raster/image_batch.h"

namespace gr::python {

// float32 holds every triangle id + 1 exactly below this count.
constexpr std::int64_t kMaxFloat32Ids = std::int64_t(1) << 24;

// (first triangle, count) per image: nvdiffrast's range mode, as Python passes it.
using Ranges = std::vector<std::pair<std::int64_t, std::int64_t>>;

// Runs a kernel call: holds the binding's lock (calls from several Python
// threads run one at a time, as the thread setting is process-wide), sets
// gradraster's thread count to `threads` when it changed, and releases the
// GIL for the duration. Declared after the call's Arrays, so it ends (the
// GIL back) before they are released.
class KernelCall {
 public:
  explicit KernelCall(int threads);

 private:
  pybind11::gil_scoped_release release_;  // first: never wait for the lock holding the GIL
  std::unique_lock<std::mutex> lock_;
};

// Calls f(T{}) with T = double when f64, else float.
template <class F>
decltype(auto) dispatch(bool f64, F&& f) {
  if (f64) return f(double{});
  return f(float{});
}

// A triangle mesh as rasterize, the peeler and antialias see it: the batch
// (raster/image_batch.h: nvdiffrast's instanced or range mode, the ranges
// checked) and its arrays, their shapes checked: pos [images, N, 4] float
// (instanced; ranges empty) or [N, 4] (range mode; one range per image), tri
// [M, 3] int32, float32 positions with fewer than 2^24 triangles. Values are
// checked by check_mesh.
struct Mesh : raster::ImageBatch {
  Mesh(const pybind11::handle& pos, const pybind11::handle& tri, const Ranges& ranges, const char* op);

  Array pos, tri;
  bool f64 = false;

  template <class T>
  const T* positions(std::int64_t b) const {
    return pos.in<T>() + pos_offset(b);
  }
  const std::int32_t* tris() const { return tri.in<std::int32_t>(); }
};

// Checks what the kernels trust (raster/mesh_checks.h): finite positions,
// every index in [0, N). Throws gr errors naming the argument.
void check_mesh(const Mesh& mesh, const char* op);

// rast: a [images, H, W, 4] G-buffer of elem's type (images < 0: any) with
// H, W < 2^31 (ValueError, TypeError otherwise).
void check_rast_shape(const Array& rast, std::int64_t images, Elem elem, const char* op);

}  // namespace gr::python
