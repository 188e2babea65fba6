// Argument checks shared by the shading functions (ops/shading/*.h), run once
// at each function's boundary. Messages follow ops/check.h's form, e.g.
//   "shading::lambert: argument 'normal' must have shape [..., 3], got float64[4, 2]".
// Also pi, for the BRDFs and the SH constants.
#pragma once

#include <cstdint>
#include <initializer_list>

#include "autodiff/base/tensor.h"

namespace gr::shading::detail {

constexpr double kPi = 3.14159265358979323846;

// A named argument of a shading function.
struct Argument {
  const char* name;
  const Tensor& tensor;
};

// DTypeError unless t is float32/float64; ShapeError unless it is [..., n]
// (rank >= 1, last extent n).
void check_vectors(const Tensor& t, std::int64_t n, const char* op, const char* name);
// DTypeError unless t is float32/float64; ShapeError unless it is one scalar
// per element: rank 0 or [..., 1] (so it cannot broadcast along a colour axis).
void check_scalars(const Tensor& t, const char* op, const char* name);
// Every argument a defined float tensor of the first one's dtype (DTypeError
// naming the first that is not), all broadcasting together (ShapeError naming
// the first argument that does not broadcast against those before it).
void check_together(const char* op, std::initializer_list<Argument> args);

}  // namespace gr::shading::detail
