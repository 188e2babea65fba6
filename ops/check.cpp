// Argument checks for ops (see check.h). The element scans (finiteness,
// index ranges) are the raster layer's parallel, thread-count independent
// ones, so the reported element never depends on the thread count.
#include "ops/check.h"

#include <cstring>

#include "autodiff/base/error.h"
#include "raster/mesh_checks.h"

namespace gr::detail {
namespace {

std::string arg(const std::string& op, const char* name) { return op + ": argument '" + name + "' "; }

// The same tensor, or one with the same shape, dtype and bits.
bool same_values(const Tensor& a, const Tensor& b) {
  if (a.same(b)) return true;
  if (!a.defined() || !b.defined() || a.dtype() != b.dtype() || a.shape() != b.shape()) return false;
  const std::size_t bytes = static_cast<std::size_t>(a.numel()) * dtype_size(a.dtype());
  return bytes == 0 || std::memcmp(a.impl()->storage->data(), b.impl()->storage->data(), bytes) == 0;
}

}  // namespace

void check_defined(const Tensor& t, const std::string& op, const char* name) {
  if (!t.defined()) throw ValueError(arg(op, name) + "is an undefined tensor");
}

void check_float(const Tensor& t, const std::string& op, const char* name) {
  check_defined(t, op, name);
  if (!is_floating(t.dtype())) throw DTypeError(arg(op, name) + "must be float32 or float64, got " + t.describe());
}

void check_dtype(const Tensor& t, DType dtype, const std::string& op, const char* name) {
  if (!t.defined() || t.dtype() != dtype)
    throw DTypeError(arg(op, name) + "must be an " + dtype_name(dtype) + " tensor, got " + t.describe());
}

void check_same_dtype(const Tensor& t, const Tensor& ref, const std::string& op, const char* name,
                      const char* ref_name) {
  if (t.dtype() != ref.dtype())
    throw DTypeError(arg(op, name) + t.describe() + " must have the dtype of '" + ref_name + "' " + ref.describe());
}

void check_same_float(const Tensor& a, const Tensor& b, const std::string& op) {
  check_float(a, op, "a");
  check_float(b, op, "b");
  if (a.dtype() != b.dtype())
    throw DTypeError(op + ": operands have different dtypes " + a.describe() + " and " + b.describe() +
                     " (use cast() to convert)");
}

void check_shape(const Tensor& t, const Shape& shape, const std::string& op, const char* name) {
  if (!t.defined() || t.shape() != shape)
    throw ShapeError(arg(op, name) + "must have shape " + shape.str() + ", got " + t.describe());
}

void check_columns(const Tensor& t, std::int64_t cols, const std::string& op, const char* name,
                   const char* rows_name) {
  if (!t.defined() || t.rank() != 2 || t.size(1) != cols)
    throw ShapeError(arg(op, name) + "must have shape [" + rows_name + ", " + std::to_string(cols) + "], got " +
                     t.describe());
}

void check_finite(const Tensor& t, const std::string& op, const char* name) {
  dispatch_float(t.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    raster::detail::check_finite(t.data<T>(), t.numel(), name, op.c_str());
  });
}

void check_image_size(std::int64_t width, std::int64_t height, const std::string& op) {
  raster::detail::check_image_size(width, height, op.c_str());
}

void check_triangles(const Tensor& triangles, std::int64_t num_vertices, const std::string& op) {
  check_dtype(triangles, DType::Int32, op, "triangles");
  check_columns(triangles, 3, op, "triangles", "M");
  raster::detail::check_triangles(triangles.data<std::int32_t>(), triangles.size(0), num_vertices, op.c_str());
}

void check_clip_and_triangles(const Tensor& clip, const Tensor& triangles, const std::string& op) {
  check_float(clip, op, "clip");
  check_columns(clip, 4, op, "clip");
  check_triangles(triangles, clip.size(0), op);
}

void check_tri_ids(const Tensor& tri_id, std::int64_t num_tris, const std::string& op) {
  raster::detail::check_tri_ids(tri_id.data<std::int32_t>(), tri_id.numel(), num_tris, op.c_str());
}

void check_gbuffer_source(const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                          const std::string& op) {
  if (!gbuffer.clip.defined()) return;
  if (!same_values(clip, gbuffer.clip))
    throw ValueError(arg(op, "clip") + "is not the clip the G-buffer was rasterized from (" +
                     gbuffer.clip.describe() + "), got " + clip.describe() +
                     " with other values: pass the tensor given to rasterize");
  if (!same_values(triangles, gbuffer.triangles))
    throw ValueError(arg(op, "triangles") + "are not the triangles the G-buffer was rasterized from (" +
                     gbuffer.triangles.describe() + "), got " + triangles.describe() +
                     " with other values: pass the tensor given to rasterize");
}

}  // namespace gr::detail
