// Mesh validation: the checks every consumer of a Mesh can rely on having
// passed (dtypes, shapes, finite attributes, triangle indices in range).
#include "raster/mesh.h"

#include <cmath>

#include "autodiff/base/error.h"

namespace gr::raster {
namespace {

// Requires `t` to be a float32 tensor of shape rows×cols (rows == -1: any).
void check_matrix(const std::string& what, const char* field, const Tensor& t, DType dtype,
                  std::int64_t rows, std::int64_t cols) {
  const std::string name = what + ": mesh." + field;
  if (!t.defined()) throw ValueError(name + " is undefined");
  if (t.dtype() != dtype)
    throw DTypeError(name + " must be " + (dtype == DType::Int32 ? "int32" : "float32") +
                     ", got " + t.describe());
  if (t.rank() != 2 || t.size(1) != cols || (rows >= 0 && t.size(0) != rows))
    throw ShapeError(name + " must have shape [" + (rows >= 0 ? std::to_string(rows) : "N") +
                     ", " + std::to_string(cols) + "], got " + t.describe());
}

// Requires every element of a float32 tensor to be finite.
void check_finite(const std::string& what, const char* field, const Tensor& t) {
  const float* d = t.data<float>();
  for (std::int64_t i = 0; i < t.numel(); ++i)
    if (!std::isfinite(d[i]))
      throw ValueError(what + ": mesh." + field + " has a non-finite value at row " +
                       std::to_string(i / t.size(1)) + ", column " +
                       std::to_string(i % t.size(1)));
}

}  // namespace

void Mesh::validate(const std::string& what) const {
  check_matrix(what, "positions", positions, DType::Float32, -1, 3);
  check_finite(what, "positions", positions);
  const std::int64_t n = positions.size(0);
  check_matrix(what, "triangles", triangles, DType::Int32, -1, 3);
  if (normals.defined()) {
    check_matrix(what, "normals", normals, DType::Float32, n, 3);
    check_finite(what, "normals", normals);
  }
  if (uvs.defined()) {
    check_matrix(what, "uvs", uvs, DType::Float32, n, 2);
    check_finite(what, "uvs", uvs);
  }
  const std::int32_t* tri = triangles.data<std::int32_t>();
  for (std::int64_t i = 0; i < triangles.numel(); ++i)
    if (tri[i] < 0 || tri[i] >= n)
      throw IndexError(what + ": mesh.triangles[" + std::to_string(i / 3) + "] refers to vertex " +
                       std::to_string(tri[i]) + ", valid range is [0, " + std::to_string(n) +
                       ")");
}

}  // namespace gr::raster
