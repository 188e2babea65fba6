// Reductions (sum, mean) and their broadcasting adjoints, side by side.
// Summation order depends on shapes only (see detail::reduce_raw), so results
// are bit-identical for any thread count.
#include "ops/tensor/reduce.h"

#include <string>
#include <vector>

#include "autodiff/base/dtype.h"
#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/check.h"
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

Tensor sum_of_products(const std::vector<Tensor>& values, const std::vector<Tensor>& weights) {
  const std::string name = "sum_of_products";
  if (values.empty()) throw ValueError(name + ": argument 'values' must hold at least one tensor");
  if (weights.size() != values.size())
    throw ValueError(name + ": argument 'weights' must hold one tensor per value (" + std::to_string(values.size()) +
                     "), got " + std::to_string(weights.size()));
  for (std::size_t k = 0; k < values.size(); ++k) {
    const std::string v = "values[" + std::to_string(k) + "]", w = "weights[" + std::to_string(k) + "]";
    detail::check_float(values[k], name, v.c_str());
    detail::check_same_dtype(values[k], values[0], name, v.c_str(), "values[0]");
    detail::check_defined(weights[k], name, w.c_str());
    detail::check_same_dtype(weights[k], values[k], name, w.c_str(), v.c_str());
    detail::check_shape(weights[k], values[k].shape(), name, w.c_str());
    if (should_record({weights[k]}))
      throw ValueError(name + ": argument '" + w + "' requires a gradient, which sum_of_products does not give (its "
                       "weights are constants); pass " + w + ".detach()");
  }
  // Each pair by fixed blocks (deterministic_sum), the pairs in order, in double.
  double total = 0;
  dispatch_float(values[0].dtype(), name, [&](auto tag) {
    using T = decltype(tag);
    for (std::size_t k = 0; k < values.size(); ++k) {
      const T* a = values[k].data<T>();
      const T* w = weights[k].data<T>();
      total += deterministic_sum<double>(values[k].numel(), kElementwiseGrain, [=](std::int64_t lo, std::int64_t hi) {
        // kLanes running sums (element i into lane (i - lo) % kLanes: vectorizable), added in lane order.
        constexpr int kLanes = 8;
        double lane[kLanes] = {};
        std::int64_t i = lo;
        for (; i + kLanes <= hi; i += kLanes)
          for (int l = 0; l < kLanes; ++l) lane[l] += double(a[i + l]) * double(w[i + l]);
        double s = 0;
        for (; i < hi; ++i) s += double(a[i]) * double(w[i]);
        for (int l = 0; l < kLanes; ++l) s += lane[l];
        return s;
      });
    }
  });
  Tensor out = Tensor::scalar(total, values[0].dtype());
  if (should_record(values)) {
    // The weights are inputs too (no gradient), so that writing them in place before backward is caught.
    std::vector<Tensor> inputs = values;
    inputs.insert(inputs.end(), weights.begin(), weights.end());
    const std::size_t pairs = values.size();
    record("sum_of_products", inputs, {&out}, [pairs, weights](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      for (std::size_t k = 0; k < pairs; ++k) {
        if (!ctx.needs_grad(k)) continue;
        dispatch_float(g.dtype(), "sum_of_products", [&](auto tag) {
          using T = decltype(tag);
          const T gv = g.data<T>()[0];
          if (gv == T(1)) return ctx.accumulate(k, weights[k]);  // 1 w = w: the same bits, no copy
          Tensor grad = Tensor::empty(weights[k].shape(), weights[k].dtype());
          const T* w = weights[k].data<T>();
          T* out = grad.data<T>();
          parallel_for(0, grad.numel(), kElementwiseGrain, [=](std::int64_t lo, std::int64_t hi) {
            for (std::int64_t i = lo; i < hi; ++i) out[i] = w[i] * gv;
          });
          ctx.accumulate(k, grad);
        });
      }
    });
  }
  return out;
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
