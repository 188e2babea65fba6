// Reductions (sum, mean) and their broadcasting adjoints, side by side.
// Summation order depends on shapes only (see detail::reduce_raw), so results
// are bit-identical for any thread count.
#include "ops/tensor/reduce.h"

#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "ops/tensor/elementwise.h"

namespace gr {
namespace {

// Shape of `a` with `axis` set to extent 1.
Shape keep_axis(const Shape& s, int axis) {
  std::vector<std::int64_t> d = s.dims();
  d[axis] = 1;
  return Shape(d);
}

Shape drop_axis(const Shape& s, int axis) {
  std::vector<std::int64_t> d = s.dims();
  d.erase(d.begin() + axis);
  return Shape(d);
}

// Sum of `a` reduced to `target`, with the result given shape `result`.
// dL/da = g broadcast back to a's shape.
Tensor sum_into(const char* name, const Tensor& a, const Shape& target, const Shape& result) {
  detail::check_float(a, name, "a");
  Tensor reduced = detail::reduce_raw(a, target);
  Tensor out = reduced.same(a) ? a.copy() : reduced.detach();
  out.impl()->shape = result;
  if (should_record({a})) {
    record(name, {a}, {&out}, [target](AdjointContext& ctx) {
      Tensor g = ctx.grad_output().detach();
      g.impl()->shape = target;
      ctx.accumulate(0, detail::expand_raw_full(g, ctx.input_shape(0)));
    });
  }
  return out;
}

}  // namespace

Tensor sum(const Tensor& a) {
  detail::check_float(a, "sum", "a");
  return sum_into("sum", a, Shape{}, Shape{});
}

Tensor sum(const Tensor& a, int axis, bool keepdim) {
  detail::check_float(a, "sum", "a");
  const int ax = a.shape().normalize_axis(axis, "sum");
  const Shape target = keep_axis(a.shape(), ax);
  return sum_into("sum", a, target, keepdim ? target : drop_axis(a.shape(), ax));
}

Tensor mean(const Tensor& a) {
  detail::check_float(a, "mean", "a");
  if (a.numel() == 0) throw ShapeError("mean: the tensor " + a.describe() + " is empty");
  return sum(a) * (1.0 / double(a.numel()));
}

Tensor mean(const Tensor& a, int axis, bool keepdim) {
  detail::check_float(a, "mean", "a");
  const int ax = a.shape().normalize_axis(axis, "mean");
  if (a.shape()[ax] == 0) throw ShapeError("mean: axis " + std::to_string(axis) + " of " + a.describe() + " is empty");
  return sum(a, ax, keepdim) * (1.0 / double(a.shape()[ax]));
}

Tensor sum_to_shape(const Tensor& a, const Shape& shape) {
  detail::check_float(a, "sum_to_shape", "a");
  if (detail::broadcast_shapes(shape, a.shape(), "sum_to_shape") != a.shape())
    throw ShapeError("sum_to_shape: shape " + shape.str() + " does not broadcast to " + a.shape().str());
  // Align ranks: the reduction target is `shape` left-padded with 1s.
  std::vector<std::int64_t> padded(static_cast<std::size_t>(a.rank() - shape.rank()), 1);
  for (std::int64_t d : shape.dims()) padded.push_back(d);
  return sum_into("sum_to_shape", a, Shape(padded), shape);
}

Tensor broadcast_to(const Tensor& a, const Shape& shape) {
  detail::check_float(a, "broadcast_to", "a");
  if (detail::broadcast_shapes(a.shape(), shape, "broadcast_to") != shape)
    throw ShapeError("broadcast_to: shape " + a.shape().str() + " does not broadcast to " + shape.str());
  Tensor out = detail::expand_raw_full(a, shape);
  if (out.same(a)) out = a.copy();
  if (should_record({a})) {
    record("broadcast_to", {a}, {&out}, [](AdjointContext& ctx) {
      ctx.accumulate(0, detail::reduce_raw(ctx.grad_output(), ctx.input_shape(0)));
    });
  }
  return out;
}

}  // namespace gr
