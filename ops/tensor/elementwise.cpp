// Elementwise ops: the evaluator of the elementwise op table's entries
// (ops/tensor/elementwise_table.h: each op's forward and adjoint formulas, shared
// with the fused row interpreter), and the ops outside it.
//
// Every table op is one of two shapes, written once: a unary map y = f(x) with
// dL/dx = df(g, x, y), or a broadcasting binary map y = f(a, b) with
// dL/da = da(g, a, b, y) and dL/db = db(g, a, b, y). Binary operands are read
// in place through a detail::RowView (full, scalar, a repeated row, or a
// column repeated along the last axis; other broadcasts are materialized), and
// an operand's adjoint is summed over the positions that read it as it is
// computed, so broadcasting costs neither a copy nor a full-size temporary.
// Full/scalar loops stay flat, contiguous and vectorizable.
#include "ops/tensor/elementwise.h"

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "ops/tensor/elementwise_table.h"
#include "ops/tensor/fusion_trace.h"
#include "ops/tensor/promote.h"

namespace gr {
namespace {

using detail::check_float;
using detail::check_same_float;
using detail::expand_raw;
using detail::power_range;
using detail::reduce_raw;

// out[i] = f(a[i]); a is full or scalar.
template <class T, class F>
void map1(const T* a, bool a_full, T* out, std::int64_t n, F f) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    if (a_full) {
      for (std::int64_t i = lo; i < hi; ++i) out[i] = f(a[i]);
    } else {
      const T av = a[0];
      for (std::int64_t i = lo; i < hi; ++i) out[i] = f(av);
    }
  });
}

// Element (r, j) of an operand read through a RowView.
template <class T>
struct Reader {
  const T* p;
  std::int64_t rs, cs;
  T operator()(std::int64_t r, std::int64_t j) const { return p[r * rs + j * cs]; }
};

template <class T>
Reader<T> reader(const detail::RowView& v) {
  return {v.tensor.template data<T>(), v.row_stride, v.col_stride};
}

std::int64_t row_grain(std::int64_t k) { return std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, k)); }

constexpr std::int64_t kRowBlock = 768;  // elements per block when a row operand is repeated

// out[r, j] = f(a(r, j), b(r, j)) over an output of rows x k.
template <class T, class F>
void map2(const detail::RowView& va, const detail::RowView& vb, T* out, F f) {
  const Reader<T> a = reader<T>(va), b = reader<T>(vb);
  const std::int64_t k = va.k;
  parallel_for(0, va.rows, row_grain(k), [&](std::int64_t r0, std::int64_t r1) {
    const std::int64_t lo = r0 * k, hi = r1 * k;
    if (va.full() && vb.full()) {
      for (std::int64_t i = lo; i < hi; ++i) out[i] = f(a.p[i], b.p[i]);
    } else if (va.full() && vb.scalar()) {
      const T bv = b.p[0];
      for (std::int64_t i = lo; i < hi; ++i) out[i] = f(a.p[i], bv);
    } else if (va.scalar() && vb.full()) {
      const T av = a.p[0];
      for (std::int64_t i = lo; i < hi; ++i) out[i] = f(av, b.p[i]);
    } else if ((va.full() && (vb.row() || vb.column())) || ((va.row() || va.column()) && vb.full())) {
      // A row operand (a [k] vector against [rows, k]) repeated, or a column
      // operand (a [..., 1] against [..., k]) spread over its row, for a block
      // of rows at a time, so each block is one flat loop (read with strides,
      // the compiler would gather).
      const bool a_small = !va.full();
      const detail::RowView& small = a_small ? va : vb;
      const T* values = a_small ? a.p : b.p;
      const T* other = a_small ? b.p : a.p;
      const std::int64_t block_rows = std::max<std::int64_t>(1, kRowBlock / k);
      std::vector<T> block(static_cast<std::size_t>(std::min(block_rows, r1 - r0) * k));
      if (small.row())  // the same for every block
        for (std::size_t e = 0; e < block.size(); ++e) block[e] = values[e % k];
      for (std::int64_t b0 = r0; b0 < r1; b0 += block_rows) {
        const std::int64_t b1 = std::min(r1, b0 + block_rows), e0 = b0 * k, e1 = b1 * k;
        if (small.column())
          for (std::int64_t r = b0; r < b1; ++r)
            for (std::int64_t j = 0; j < k; ++j) block[static_cast<std::size_t>((r - b0) * k + j)] = values[r];
        const T* rep = block.data() - e0;
        if (a_small)
          for (std::int64_t e = e0; e < e1; ++e) out[e] = f(rep[e], other[e]);
        else
          for (std::int64_t e = e0; e < e1; ++e) out[e] = f(other[e], rep[e]);
      }
    } else {  // both broadcast: walk the output row by row
      for (std::int64_t r = r0; r < r1; ++r) {
        const T* ar = a.p + r * a.rs;
        const T* br = b.p + r * b.rs;
        T* o = out + r * k;
        for (std::int64_t j = 0; j < k; ++j) o[j] = f(ar[j * a.cs], br[j * b.cs]);
      }
    }
  });
}

bool is_full(const Tensor& t, std::int64_t n) { return t.numel() == n; }

// Two operands checked and viewed against their broadcast shape.
struct Operands {
  Shape shape;
  detail::RowView a, b;
};

Operands broadcast_operands(const char* name, const Tensor& a, const Tensor& b) {
  check_same_float(a, b, name);
  const Shape shape = detail::broadcast_shapes(a.shape(), b.shape(), name);
  return {shape, detail::row_view(a, shape), detail::row_view(b, shape)};
}

// out = f(a, b) elementwise over broadcast operands.
template <class F>
Tensor map_operands(const char* name, const Operands& o, F f) {
  Tensor out = Tensor::empty(o.shape, o.a.tensor.dtype());
  dispatch_float(out.dtype(), name, [&](auto tag) {
    using T = decltype(tag);
    map2<T>(o.a, o.b, out.data<T>(), [&](T x, T z) { return T(f(x, z)); });
  });
  return out;
}

// Adds the adjoint of operand `input` (read through v) to ctx: the sum, over
// the output positions that read each operand element, of term(i, r, j)
// (see detail::sum_into_operand; term returns T).
template <class T, class Term>
void accumulate_operand(AdjointContext& ctx, std::size_t input, const detail::RowView& v, Term term) {
  if (v.materialized) {  // full-size gradient, then summed back to the operand's shape
    Tensor full = Tensor::empty(v.tensor.shape(), v.tensor.dtype());
    detail::sum_into_operand<T>(v, term, full.data<T>());
    ctx.accumulate(input, reduce_raw(full, ctx.input_shape(input)));
    return;
  }
  Tensor grad = Tensor::empty(ctx.input_shape(input), ctx.input_dtype(input));
  detail::sum_into_operand<T>(v, term, grad.data<T>());
  ctx.accumulate(input, grad);
}

// y = f(x); dL/dx = df(g, x, y).
template <class Fwd, class Bwd>
Tensor unary(const char* name, const Tensor& a, Fwd fwd, Bwd df) {
  check_float(a, name, "a");
  Tensor out = Tensor::empty(a.shape(), a.dtype());
  dispatch_float(a.dtype(), name, [&](auto tag) {
    using T = decltype(tag);
    map1(a.data<T>(), true, out.data<T>(), a.numel(), [&](T x) { return T(fwd(x)); });
  });
  if (should_record({a})) {
    Tensor y = out.detach();
    record(name, {a}, {&out}, [a, y, df, name](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      Tensor ga = Tensor::empty(a.shape(), a.dtype());
      dispatch_float(a.dtype(), name, [&](auto tag) {
        using T = decltype(tag);
        const T *pg = g.data<T>(), *px = a.data<T>(), *py = y.data<T>();
        T* d = ga.data<T>();
        parallel_for(0, a.numel(), kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
          for (std::int64_t i = lo; i < hi; ++i) d[i] = T(df(pg[i], px[i], py[i]));
        });
      });
      ctx.accumulate(0, ga);
    });
  }
  return out;
}

// y = f(a, b) with broadcasting; dL/da = da(g, a, b, y), dL/db = db(g, a, b, y).
// The output y is kept for the adjoint only when `uses_y` (else it is passed as 0).
template <class Fwd, class DA, class DB>
Tensor binary(const char* name, Tensor a, Tensor b, bool uses_y, Fwd fwd, DA da, DB db) {
  detail::promote_floats({&a, &b});
  const Operands o = broadcast_operands(name, a, b);
  Tensor out = map_operands(name, o, fwd);
  if (should_record({a, b})) {
    Tensor y = uses_y ? out.detach() : Tensor();
    record(name, {a, b}, {&out}, [va = o.a, vb = o.b, y, da, db, name](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      dispatch_float(g.dtype(), name, [&](auto tag) {
        using T = decltype(tag);
        const Reader<T> ra = reader<T>(va), rb = reader<T>(vb);
        const T* pg = g.data<T>();
        const T* py = y.defined() ? y.data<T>() : nullptr;
        // y_at(i) is y[i], or 0 when y is not kept.
        auto side_with = [&](std::size_t input, const detail::RowView& v, auto f, auto y_at) {
          if (va.full() && vb.full()) {  // flat, vectorizable
            const T *pa = ra.p, *pb = rb.p;
            accumulate_operand<T>(ctx, input, v, [&](std::int64_t i, std::int64_t, std::int64_t) {
              return T(f(pg[i], pa[i], pb[i], y_at(i)));
            });
          } else if (va.full() && vb.scalar()) {  // e.g. maximum(x, 0.0): flat as well
            const T* pa = ra.p;
            const T b0 = rb.p[0];
            accumulate_operand<T>(ctx, input, v, [&](std::int64_t i, std::int64_t, std::int64_t) {
              return T(f(pg[i], pa[i], b0, y_at(i)));
            });
          } else if (va.scalar() && vb.full()) {
            const T a0 = ra.p[0], *pb = rb.p;
            accumulate_operand<T>(ctx, input, v, [&](std::int64_t i, std::int64_t, std::int64_t) {
              return T(f(pg[i], a0, pb[i], y_at(i)));
            });
          } else if (va.full() && vb.column()) {  // e.g. albedo * max(n.l, 0): no strided reads
            const T *pa = ra.p, *pb = rb.p;
            accumulate_operand<T>(ctx, input, v, [&](std::int64_t i, std::int64_t r, std::int64_t) {
              return T(f(pg[i], pa[i], pb[r], y_at(i)));
            });
          } else if (va.column() && vb.full()) {
            const T *pa = ra.p, *pb = rb.p;
            accumulate_operand<T>(ctx, input, v, [&](std::int64_t i, std::int64_t r, std::int64_t) {
              return T(f(pg[i], pa[r], pb[i], y_at(i)));
            });
          } else {
            accumulate_operand<T>(ctx, input, v, [&](std::int64_t i, std::int64_t r, std::int64_t j) {
              return T(f(pg[i], ra(r, j), rb(r, j), y_at(i)));
            });
          }
        };
        auto one_side = [&](std::size_t input, const detail::RowView& v, auto f) {
          if (!ctx.needs_grad(input)) return;
          if (py) side_with(input, v, f, [py](std::int64_t i) { return py[i]; });
          else side_with(input, v, f, [](std::int64_t) { return T(0); });
        };
        one_side(0, va, da);
        one_side(1, vb, db);
      });
    });
  }
  return out;
}

// add/sub: the adjoint is +-g summed back to each operand's shape (g itself
// for a full operand of a's shape).
template <class Op>
Tensor add_or_sub(Tensor a, Tensor b) {
  detail::promote_floats({&a, &b});
  const Operands o = broadcast_operands(Op::name, a, b);
  Tensor out = map_operands(Op::name, o, [](auto x, auto z) { return Op::forward(x, z); });
  if (should_record({a, b})) {
    record(Op::name, {a, b}, {&out}, [](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (ctx.needs_grad(0)) ctx.accumulate(0, reduce_raw(g, ctx.input_shape(0)));
      if (ctx.needs_grad(1)) {
        Tensor gb = reduce_raw(g, ctx.input_shape(1));
        ctx.accumulate(1, Op::negate_b ? neg(gb) : gb);
      }
    });
  }
  return out;
}

// A comparison mask: 1 where rel(a, b), else 0. No gradient.
template <class Rel>
Tensor compare(const char* name, Tensor a, Tensor b, Rel rel) {
  detail::promote_floats({&a, &b});
  return map_operands(name, broadcast_operands(name, a, b),
                      [&](auto x, auto z) { return rel(x, z) ? decltype(x)(1) : decltype(x)(0); });
}

// x^p elementwise.
template <class T>
void power(const T* x, T* out, std::int64_t n, double p) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) { power_range(x, out, lo, hi, p); });
}

}  // namespace

Tensor scalar_like(const Tensor& a, double value) {
  check_float(a, "scalar_like", "a");
  return Tensor::scalar(value, a.dtype());
}

// The table's entries (ops/tensor/elementwise_table.h) as eager ops. Each notes
// itself on an active trace (ops/tensor/fusion_trace.h), for the fused row
// interpreter, which replays the same entry.
template <class Op>
static Tensor unary_entry(const Tensor& a) {
  Tensor out = unary(Op::name, a, [](auto x) { return Op::forward(x); },
                     [](auto g, auto x, auto y) { return Op::adjoint(g, x, y); });
  detail::trace_step(detail::op_id<Op>(), a, Tensor(), out);
  return out;
}

template <class Op>
static Tensor binary_entry(const Tensor& a, const Tensor& b) {
  Tensor out;
  if constexpr (Op::linear)
    out = add_or_sub<Op>(a, b);
  else
    out = binary(Op::name, a, b, Op::uses_result, [](auto x, auto z) { return Op::forward(x, z); },
                 [](auto g, auto x, auto z, auto y) { return Op::adjoint_a(g, x, z, y); },
                 [](auto g, auto x, auto z, auto y) { return Op::adjoint_b(g, x, z, y); });
  detail::trace_step(detail::op_id<Op>(), a, b, out);
  return out;
}

namespace detail {

const char* op_name(OpId op) {
  const char* name = "";
  switch (op.kind) {
    case OpKind::Unary: visit_entry(UnaryOps{}, op.index, [&](auto entry) { name = decltype(entry)::name; }); break;
    case OpKind::Binary: visit_entry(BinaryOps{}, op.index, [&](auto entry) { name = decltype(entry)::name; }); break;
    case OpKind::Power: name = "pow"; break;
    case OpKind::Clamp: name = ClampOp::name; break;
    case OpKind::Dot: name = "dot"; break;
    case OpKind::Normalize: name = "normalize"; break;
  }
  return name;
}

Tensor eager_op(OpId op, const Tensor& a, const Tensor& b) {
  const int entries = op.kind == OpKind::Unary ? UnaryOps::size : op.kind == OpKind::Binary ? BinaryOps::size : 0;
  if (op.index < 0 || op.index >= entries)
    throw ValueError(std::string("eager_op: ") + (entries ? "index " + std::to_string(op.index) : op_name(op)) +
                     " is not an entry of the elementwise table");
  Tensor out;
  if (op.kind == OpKind::Unary)
    visit_entry(UnaryOps{}, op.index, [&](auto entry) { out = unary_entry<decltype(entry)>(a); });
  else
    visit_entry(BinaryOps{}, op.index, [&](auto entry) { out = binary_entry<decltype(entry)>(a, b); });
  return out;
}

}  // namespace detail

Tensor add(const Tensor& a, const Tensor& b) { return binary_entry<detail::AddOp>(a, b); }
Tensor sub(const Tensor& a, const Tensor& b) { return binary_entry<detail::SubOp>(a, b); }
Tensor mul(const Tensor& a, const Tensor& b) { return binary_entry<detail::MulOp>(a, b); }
Tensor div(const Tensor& a, const Tensor& b) { return binary_entry<detail::DivOp>(a, b); }
Tensor pow(const Tensor& a, const Tensor& b) { return binary_entry<detail::PowOp>(a, b); }
Tensor minimum(const Tensor& a, const Tensor& b) { return binary_entry<detail::MinimumOp>(a, b); }
Tensor maximum(const Tensor& a, const Tensor& b) { return binary_entry<detail::MaximumOp>(a, b); }

Tensor neg(const Tensor& a) { return unary_entry<detail::NegOp>(a); }
Tensor exp(const Tensor& a) { return unary_entry<detail::ExpOp>(a); }
Tensor log(const Tensor& a) { return unary_entry<detail::LogOp>(a); }
Tensor sqrt(const Tensor& a) { return unary_entry<detail::SqrtOp>(a); }
Tensor rsqrt(const Tensor& a) { return unary_entry<detail::RsqrtOp>(a); }
Tensor sin(const Tensor& a) { return unary_entry<detail::SinOp>(a); }
Tensor cos(const Tensor& a) { return unary_entry<detail::CosOp>(a); }
Tensor abs(const Tensor& a) { return unary_entry<detail::AbsOp>(a); }

// pow with a constant exponent: the range kernels both evaluators share
// (detail::power_range, detail::power_adjoint_range).
Tensor pow(const Tensor& a, double p) {
  check_float(a, "pow", "a");
  Tensor out = Tensor::empty(a.shape(), a.dtype());
  dispatch_float(a.dtype(), "pow", [&](auto tag) {
    using T = decltype(tag);
    power(a.data<T>(), out.data<T>(), a.numel(), p);
  });
  if (should_record({a})) {
    record("pow", {a}, {&out}, [a, p](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      Tensor ga = Tensor::empty(a.shape(), a.dtype());
      dispatch_float(a.dtype(), "pow", [&](auto tag) {
        using T = decltype(tag);
        // dL/da = g p a^(p-1) (detail::power_adjoint_range).
        T* d = ga.data<T>();
        const T *x = a.data<T>(), *gp = g.data<T>();
        parallel_for(0, a.numel(), kElementwiseGrain,
                     [&](std::int64_t lo, std::int64_t hi) { detail::power_adjoint_range(gp, x, d, lo, hi, p); });
      });
      ctx.accumulate(0, ga);
    });
  }
  detail::trace_step(detail::OpId{detail::OpKind::Power}, a, Tensor(), out, p);
  return out;
}

Tensor clamp(const Tensor& a, double lo, double hi) {
  if (!(lo <= hi)) throw ValueError("clamp: lower bound " + std::to_string(lo) + " exceeds upper bound " + std::to_string(hi));
  using detail::ClampOp;
  Tensor out = unary(
      ClampOp::name, a, [lo, hi](auto x) { return ClampOp::forward(x, decltype(x)(lo), decltype(x)(hi)); },
      [lo, hi](auto g, auto x, auto) { return ClampOp::adjoint(g, x, decltype(x)(lo), decltype(x)(hi)); });
  detail::trace_step(detail::OpId{detail::OpKind::Clamp}, a, Tensor(), out, lo, hi);
  return out;
}

Tensor less(const Tensor& a, const Tensor& b) { return compare("less", a, b, [](auto x, auto z) { return x < z; }); }
Tensor less_equal(const Tensor& a, const Tensor& b) { return compare("less_equal", a, b, [](auto x, auto z) { return x <= z; }); }
Tensor greater(const Tensor& a, const Tensor& b) { return compare("greater", a, b, [](auto x, auto z) { return x > z; }); }
Tensor greater_equal(const Tensor& a, const Tensor& b) { return compare("greater_equal", a, b, [](auto x, auto z) { return x >= z; }); }
Tensor equal(const Tensor& a, const Tensor& b) { return compare("equal", a, b, [](auto x, auto z) { return x == z; }); }
Tensor not_equal(const Tensor& a, const Tensor& b) { return compare("not_equal", a, b, [](auto x, auto z) { return x != z; }); }

Tensor where(const Tensor& mask_in, const Tensor& a_in, const Tensor& b_in) {
  Tensor mask = mask_in, a = a_in, b = b_in;
  detail::promote_floats({&mask, &a, &b});
  check_float(mask, "where", "mask");
  check_same_float(a, b, "where");
  detail::check_same_dtype(mask, a, "where", "mask", "a");
  const Shape shape = detail::broadcast_shapes(mask.shape(), detail::broadcast_shapes(a.shape(), b.shape(), "where"), "where");
  const std::int64_t n = shape.numel();
  const Tensor em = expand_raw(mask, shape), ea = expand_raw(a, shape), eb = expand_raw(b, shape);
  Tensor out = Tensor::empty(shape, a.dtype());
  dispatch_float(a.dtype(), "where", [&](auto tag) {
    using T = decltype(tag);
    const T* m = em.data<T>();
    const bool m_full = is_full(em, n);
    const T* pa = ea.data<T>();
    const T* pb = eb.data<T>();
    const bool a_full = is_full(ea, n), b_full = is_full(eb, n);
    T* o = out.data<T>();
    parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t i = lo; i < hi; ++i)
        o[i] = m[m_full ? i : 0] != T(0) ? pa[a_full ? i : 0] : pb[b_full ? i : 0];
    });
  });
  if (should_record({a, b})) {
    // The mask, detached (no gradient), so that backward() refuses it written in place.
    record("where", {a, b, em.detach()}, {&out}, [em, m_full = is_full(em, n)](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      for (std::size_t input = 0; input < 2; ++input) {
        if (!ctx.needs_grad(input)) continue;
        // dL/da = g where mask, dL/db = g where !mask.
        Tensor full = Tensor::empty(g.shape(), g.dtype());
        dispatch_float(g.dtype(), "where", [&](auto tag) {
          using T = decltype(tag);
          const T* m = em.data<T>();
          const T* gp = g.data<T>();
          T* d = full.data<T>();
          const bool take_when_set = input == 0;
          parallel_for(0, g.numel(), kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
            for (std::int64_t i = lo; i < hi; ++i)
              d[i] = ((m[m_full ? i : 0] != T(0)) == take_when_set) ? gp[i] : T(0);
          });
        });
        ctx.accumulate(input, reduce_raw(full, ctx.input_shape(input)));
      }
    });
  }
  return out;
}

Tensor cast(const Tensor& a, DType dtype) {
  if (!a.defined()) throw ValueError("cast: argument 'a' is an undefined tensor");
  if (a.dtype() == dtype) return a;
  Tensor out = Tensor::empty(a.shape(), dtype);
  const std::int64_t n = a.numel();
  // Float to int32 truncates toward zero; NaN, Inf and values outside the int32
  // range have no int32 (converting them is undefined behaviour): the first such
  // element, found the same way for any thread count, is refused.
  std::atomic<std::int64_t> first_bad{n};
  auto note_bad = [&](std::int64_t i) {  // keeps the smallest index
    std::int64_t seen = first_bad.load();
    while (i < seen && !first_bad.compare_exchange_weak(seen, i)) {
    }
  };
  auto convert = [&](auto src_tag, auto dst_tag) {
    using S = decltype(src_tag);
    using D = decltype(dst_tag);
    constexpr bool to_int = std::is_same<D, std::int32_t>::value && std::is_floating_point<S>::value;
    const S* s = a.data<S>();
    D* d = out.data<D>();
    parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t i = lo; i < hi; ++i) {
        if (to_int && !(double(s[i]) >= -2147483648.0 && double(s[i]) < 2147483648.0)) {
          note_bad(i);
          d[i] = D(0);
        } else {
          d[i] = static_cast<D>(s[i]);
        }
      }
    });
  };
  auto with_dst = [&](auto src_tag) {
    switch (dtype) {
      case DType::Float32: convert(src_tag, float{}); break;
      case DType::Float64: convert(src_tag, double{}); break;
      case DType::Int32: convert(src_tag, std::int32_t{}); break;
    }
  };
  switch (a.dtype()) {
    case DType::Float32: with_dst(float{}); break;
    case DType::Float64: with_dst(double{}); break;
    case DType::Int32: with_dst(std::int32_t{}); break;
  }
  if (first_bad.load() < n) {
    const std::int64_t i = first_bad.load();
    char value[32];
    std::snprintf(value, sizeof value, "%.17g", a.dtype() == DType::Float32 ? double(a.data<float>()[i]) : a.data<double>()[i]);
    throw ValueError("cast: a[" + std::to_string(i) + "] = " + value +
                     " has no int32 value (NaN, infinite or outside [-2147483648, 2147483647])");
  }
  // Gradients flow between float dtypes only; an int32 result is a constant.
  if (is_floating(a.dtype()) && is_floating(dtype) && should_record({a})) {
    const DType back = a.dtype();
    record("cast", {a}, {&out}, [back](AdjointContext& ctx) { ctx.accumulate(0, cast(ctx.grad_output(), back)); });
  }
  return out;
}

}  // namespace gr
