#include "ops/tensor/promote.h"

#include <string>

#include "ops/tensor/elementwise.h"

namespace gr {

DType promote_types(DType a, DType b) {
  if (!is_floating(a) || !is_floating(b))
    throw DTypeError(std::string("promote_types: only float32 and float64 promote, got ") + dtype_name(a) + " and " +
                     dtype_name(b));
  return a == DType::Float64 || b == DType::Float64 ? DType::Float64 : DType::Float32;
}

namespace detail {

void promote_floats(std::initializer_list<Tensor*> operands) {
  bool any64 = false;
  for (const Tensor* t : operands) any64 |= t->defined() && t->dtype() == DType::Float64;
  if (!any64) return;
  for (Tensor* t : operands)
    if (t->defined() && t->dtype() == DType::Float32) *t = cast(*t, DType::Float64);
}

}  // namespace detail
}  // namespace gr
