// Vector ops on the last axis (dot, cross, length, normalize, reflect): forward
// kernels and their adjoints side by side.
//
// Operands are broadcast over their leading axes to one full shape (the last
// axes must agree), so each kernel walks contiguous rows of K elements. Every
// output row is computed by exactly one thread in a fixed order, so results do
// not depend on the thread count; adjoints of broadcast operands are summed
// back with detail::reduce_raw, which is deterministic as well.
#include "ops/tensor/vector.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"
#include "ops/tensor/elementwise.h"
#include "ops/tensor/elementwise_formulas.h"
#include "ops/tensor/fusion_trace.h"

namespace gr {
namespace {

using detail::expand_raw_full;
using detail::reduce_raw;

// Accumulator type of per-row sums: double for float32 too (cheap, and it keeps
// tiny float32 vectors from underflowing to length 0).
using Acc = double;

// Rows per parallel chunk for rows of k elements.
std::int64_t row_grain(std::int64_t k) { return std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, k)); }

// Checks that `v` is a float tensor with at least one axis (and, if
// `required` > 0, last-axis extent `required`).
void check_vector(const Tensor& v, const std::string& op, const char* name, std::int64_t required = -1) {
  detail::check_float(v, op, name);
  if (v.rank() < 1)
    throw ShapeError(op + ": argument '" + name + "' must have at least one axis (vectors on the last axis), got " +
                     v.describe());
  if (required > 0 && v.size(-1) != required)
    throw ShapeError(op + ": argument '" + name + "' must have last axis of extent " + std::to_string(required) +
                     ", got " + v.describe());
}

// Validates two vector operands and returns their broadcast (full) shape.
Shape vector_pair(const Tensor& a, const Tensor& b, const std::string& op, const char* na, const char* nb,
                  std::int64_t required = -1) {
  check_vector(a, op, na, required);
  check_vector(b, op, nb, required);
  if (a.dtype() != b.dtype())
    throw DTypeError(op + ": arguments '" + na + "' and '" + nb + "' have different dtypes " + a.describe() +
                     " and " + b.describe() + " (use cast() to convert)");
  if (a.size(-1) != b.size(-1))
    throw ShapeError(op + ": last axes of '" + na + "' " + a.shape().str() + " and '" + nb + "' " +
                     b.shape().str() + " differ (expected equal vector lengths)");
  return detail::broadcast_shapes(a.shape(), b.shape(), op);
}

// Shape `s` with its last axis set to extent 1.
Shape last_to_one(const Shape& s) {
  std::vector<std::int64_t> d = s.dims();
  d.back() = 1;
  return Shape(d);
}

// Euclidean length of one row of k elements, accumulated in double.
template <class T>
Acc row_length(const T* v, std::int64_t k) {
  Acc s = 0;
  for (std::int64_t j = 0; j < k; ++j) s += Acc(v[j]) * Acc(v[j]);
  return std::sqrt(s);
}

// per_element[3 i + j] = per_row[i] for j < 3: a row's value beside each of
// its elements, so the loop that uses it is flat and vectorizes.
template <class V>
void spread_rows3(const V* per_row, V* per_element, std::int64_t rows) {
  for (std::int64_t i = 0; i < rows; ++i) per_element[3 * i] = per_element[3 * i + 1] = per_element[3 * i + 2] = per_row[i];
}

constexpr std::int64_t kRows3Block = 128;  // rows per block of the rows-of-3 kernels

// s[i] = a[3i] b[3i] + a[3i+1] b[3i+1] + a[3i+2] b[3i+2] in double for
// i < rows <= kRows3Block, added left to right from 0 (the per-row loops'
// order, so the same bits): the products as one flat loop the compiler
// vectorizes, then the sums.
template <class T>
void row_dots3(const T* a, const T* b, Acc* s, std::int64_t rows) {
  Acc prod[3 * kRows3Block];
  for (std::int64_t e = 0; e < 3 * rows; ++e) prod[e] = Acc(a[e]) * Acc(b[e]);
  for (std::int64_t i = 0; i < rows; ++i) s[i] = Acc(0) + prod[3 * i] + prod[3 * i + 1] + prod[3 * i + 2];
}

// normalize's forward on rows of 3, the general loop's operations in the same
// order (so the same bits), in blocks: the lengths, one denominator per
// element, then the quotients as one flat loop the compiler vectorizes.
template <class T>
void normalize_rows3(const T* v, T* out, T* denom, std::int64_t rows, double eps) {
  constexpr std::int64_t kRows = kRows3Block;
  Acc d[kRows], inv[kRows], d3[3 * kRows], inv3[3 * kRows];
  for (std::int64_t r0 = 0; r0 < rows; r0 += kRows) {
    const std::int64_t n = std::min(kRows, rows - r0);
    const T* x = v + 3 * r0;
    row_dots3(x, x, d, n);
    for (std::int64_t i = 0; i < n; ++i) d[i] = std::max<Acc>(std::sqrt(d[i]), eps);
    for (std::int64_t i = 0; i < n; ++i) denom[r0 + i] = T(d[i]);
    spread_rows3(d, d3, n);
    if constexpr (std::is_same_v<T, float>) {  // normalized()'s two forms as flat loops
      for (std::int64_t i = 0; i < n; ++i) inv[i] = 1 / d[i];
      spread_rows3(inv, inv3, n);
      for (std::int64_t e = 0; e < 3 * n; ++e) out[3 * r0 + e] = T(Acc(x[e]) * inv3[e]);
    } else {
      for (std::int64_t e = 0; e < 3 * n; ++e) out[3 * r0 + e] = T(Acc(x[e]) / d3[e]);
    }
  }
}

// normalize's adjoint on rows of 3, the general loop's operations in the same
// order: per row n.g and 1/d, spread to one value per element, then
// (g - n (n.g)) / d as one flat loop; rows at or below eps take g / eps after.
template <class T>
void normalize_adjoint_rows3(const T* n, const T* g, const T* denom, T* out, std::int64_t rows, double eps) {
  constexpr std::int64_t kRows = kRows3Block;
  Acc ng[kRows], inv[kRows], ng3[3 * kRows], inv3[3 * kRows];
  for (std::int64_t r0 = 0; r0 < rows; r0 += kRows) {
    const std::int64_t m = std::min(kRows, rows - r0);
    const T *nb = n + 3 * r0, *gb = g + 3 * r0;
    row_dots3(nb, gb, ng, m);
    for (std::int64_t i = 0; i < m; ++i) inv[i] = 1 / Acc(denom[r0 + i]);
    spread_rows3(ng, ng3, m);
    spread_rows3(inv, inv3, m);
    T* ob = out + 3 * r0;
    for (std::int64_t e = 0; e < 3 * m; ++e) ob[e] = T((Acc(gb[e]) - Acc(nb[e]) * ng3[e]) * inv3[e]);
    // Below eps the op is v / eps: dL/dv = g / eps, which is g itself where g is
    // +-0 (the background of an image, where no gradient arrives): no division.
    for (std::int64_t i = 0; i < m; ++i)
      if (!(denom[r0 + i] > T(eps)))
        for (int j = 0; j < 3; ++j) {
          const T gj = gb[3 * i + j];
          ob[3 * i + j] = gj == T(0) ? gj : T(Acc(gj) / eps);
        }
  }
}

// out[r, j] = g[r] y[r, j]. Rows of 3 in blocks, g spread to one factor per
// element first, so the products are one flat loop the compiler vectorizes.
template <class T>
void scale_rows(const T* g, const T* y, T* out, std::int64_t rows, std::int64_t k) {
  if (k != 3) {
    for (std::int64_t r = 0; r < rows; ++r)
      for (std::int64_t j = 0; j < k; ++j) out[r * k + j] = g[r] * y[r * k + j];
    return;
  }
  constexpr std::int64_t kRows = kRows3Block;
  T g3[3 * kRows];
  for (std::int64_t r0 = 0; r0 < rows; r0 += kRows) {
    const std::int64_t n = std::min(kRows, rows - r0);
    spread_rows3(g + r0, g3, n);
    for (std::int64_t e = 0; e < 3 * n; ++e) out[3 * r0 + e] = g3[e] * y[3 * r0 + e];
  }
}

// A dot operand on rows of 3: the tensor's rows, or its one row [3] repeated
// over all of them (a light or half vector against [N, 3] pixels), read from a
// per-chunk block of repeats instead of an [N, 3] copy.
template <class T>
struct Rows3 {
  const T* p;
  bool repeated;
  T block[3 * kRows3Block];
  Rows3(const T* data, bool row) : p(data), repeated(row) {
    if (row)
      for (std::int64_t e = 0; e < 3 * kRows3Block; ++e) block[e] = data[e % 3];
  }
  const T* at(std::int64_t r0) const { return repeated ? block : p + 3 * r0; }  // rows r0 .. r0 + kRows3Block
};

}  // namespace

Tensor dot(const Tensor& a, const Tensor& b) {
  const Shape full = vector_pair(a, b, "dot", "a", "b");
  const std::int64_t k = full[-1];
  // Rows of 3 read a single-row operand in place; anything else is expanded.
  const bool a_row = k == 3 && a.numel() == 3, b_row = k == 3 && b.numel() == 3;
  const Tensor ea = a_row ? a : expand_raw_full(a, full), eb = b_row ? b : expand_raw_full(b, full);
  Tensor out = Tensor::empty(last_to_one(full), a.dtype());
  dispatch_float(a.dtype(), "dot", [&](auto tag) {
    using T = decltype(tag);
    const T *pa = ea.data<T>(), *pb = eb.data<T>();
    T* po = out.data<T>();
    // out[r] = sum_j a[r, j] b[r, j], one row per output element.
    parallel_for(0, out.numel(), row_grain(k), [&](std::int64_t lo, std::int64_t hi) {
      if (k == 3) {
        const Rows3<T> ra(pa, a_row), rb(pb, b_row);
        Acc s[kRows3Block];
        for (std::int64_t r0 = lo; r0 < hi; r0 += kRows3Block) {
          const std::int64_t n = std::min(kRows3Block, hi - r0);
          row_dots3(ra.at(r0), rb.at(r0), s, n);
          for (std::int64_t i = 0; i < n; ++i) po[r0 + i] = T(s[i]);
        }
        return;
      }
      for (std::int64_t r = lo; r < hi; ++r) {
        Acc s = 0;
        for (std::int64_t j = 0; j < k; ++j) s += Acc(pa[r * k + j]) * Acc(pb[r * k + j]);
        po[r] = T(s);
      }
    });
  });
  if (should_record({a, b})) {
    record("dot", {a, b}, {&out}, [ea, eb, a_row, b_row, k, full](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      dispatch_float(g.dtype(), "dot", [&](auto tag) {
        using T = decltype(tag);
        // dL/dx[r, j] = g[r] y[r, j] for (x, y) = (a, b) and (b, a).
        auto side = [&](std::size_t input, const Tensor& other, bool other_row) {
          if (!ctx.needs_grad(input)) return;
          Tensor grad_full = Tensor::empty(full, other.dtype());
          const T* pg = g.data<T>();
          const T* py = other.data<T>();
          T* pf = grad_full.data<T>();
          parallel_for(0, g.numel(), row_grain(k), [&](std::int64_t lo, std::int64_t hi) {
            if (k != 3) {
              scale_rows(pg + lo, py + lo * k, pf + lo * k, hi - lo, k);
              return;
            }
            const Rows3<T> y(py, other_row);
            for (std::int64_t r0 = lo; r0 < hi; r0 += kRows3Block)
              scale_rows(pg + r0, y.at(r0), pf + 3 * r0, std::min(kRows3Block, hi - r0), 3);
          });
          ctx.accumulate(input, reduce_raw(grad_full, ctx.input_shape(input)));
        };
        side(0, eb, b_row);
        side(1, ea, a_row);
      });
    });
  }
  detail::trace_step(detail::OpId{detail::OpKind::Dot}, a, b, out);
  return out;
}

Tensor cross(const Tensor& a, const Tensor& b) {
  const Shape full = vector_pair(a, b, "cross", "a", "b", 3);
  const Tensor ea = expand_raw_full(a, full), eb = expand_raw_full(b, full);
  Tensor out = Tensor::empty(full, a.dtype());
  // c = x X y for rows of 3, written as a kernel shared by forward and adjoint.
  auto cross_rows = [](auto tag, const Tensor& x, const Tensor& y, Tensor& c) {
    using T = decltype(tag);
    const T *px = x.data<T>(), *py = y.data<T>();
    T* pc = c.data<T>();
    parallel_for(0, c.numel() / 3, row_grain(3), [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t r = lo; r < hi; ++r) {
        const T* u = px + 3 * r;
        const T* v = py + 3 * r;
        T* w = pc + 3 * r;
        w[0] = u[1] * v[2] - u[2] * v[1];
        w[1] = u[2] * v[0] - u[0] * v[2];
        w[2] = u[0] * v[1] - u[1] * v[0];
      }
    });
  };
  dispatch_float(a.dtype(), "cross", [&](auto tag) { cross_rows(tag, ea, eb, out); });
  if (should_record({a, b})) {
    record("cross", {a, b}, {&out}, [ea, eb, cross_rows](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      dispatch_float(g.dtype(), "cross", [&](auto tag) {
        // g . (a x b) = a . (b x g) = b . (g x a): dL/da = b x g, dL/db = g x a.
        if (ctx.needs_grad(0)) {
          Tensor full = Tensor::empty(g.shape(), g.dtype());
          cross_rows(tag, eb, g, full);
          ctx.accumulate(0, reduce_raw(full, ctx.input_shape(0)));
        }
        if (ctx.needs_grad(1)) {
          Tensor full = Tensor::empty(g.shape(), g.dtype());
          cross_rows(tag, g, ea, full);
          ctx.accumulate(1, reduce_raw(full, ctx.input_shape(1)));
        }
      });
    });
  }
  return out;
}

Tensor length(const Tensor& v, double eps) {
  check_vector(v, "length", "v");
  if (!(eps > 0)) throw ValueError("length: eps must be positive, got " + std::to_string(eps));
  const std::int64_t k = v.size(-1);
  Tensor out = Tensor::empty(last_to_one(v.shape()), v.dtype());
  dispatch_float(v.dtype(), "length", [&](auto tag) {
    using T = decltype(tag);
    const T* pv = v.data<T>();
    T* po = out.data<T>();
    // out[r] = sqrt(sum_j v[r, j]^2).
    parallel_for(0, out.numel(), row_grain(k), [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t r = lo; r < hi; ++r) po[r] = T(row_length(pv + r * k, k));
    });
  });
  if (should_record({v})) {
    Tensor len = out.detach();
    record("length", {v}, {&out}, [v, len, k, eps](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor gv = Tensor::empty(v.shape(), v.dtype());
      dispatch_float(v.dtype(), "length", [&](auto tag) {
        using T = decltype(tag);
        const T *pv = v.data<T>(), *pl = len.data<T>(), *pg = g.data<T>();
        T* po = gv.data<T>();
        // dL/dv[r, j] = g[r] v[r, j] / max(|v[r]|, eps)  (0 at v == 0).
        parallel_for(0, len.numel(), row_grain(k), [&](std::int64_t lo, std::int64_t hi) {
          for (std::int64_t r = lo; r < hi; ++r) {
            const T s = T(pg[r] / std::max<T>(pl[r], T(eps)));
            for (std::int64_t j = 0; j < k; ++j) po[r * k + j] = s * pv[r * k + j];
          }
        });
      });
      ctx.accumulate(0, gv);
    });
  }
  return out;
}

Tensor normalize(const Tensor& v, double eps) {
  check_vector(v, "normalize", "v");
  if (!(eps > 0)) throw ValueError("normalize: eps must be positive, got " + std::to_string(eps));
  const std::int64_t k = v.size(-1);
  const std::int64_t rows = k == 0 ? 0 : v.numel() / k;
  Tensor out = Tensor::empty(v.shape(), v.dtype());
  // Per row d = max(|v|, eps), kept for the adjoint instead of v itself (k
  // times smaller, and v's buffer can be recycled as soon as it dies).
  Tensor denom = Tensor::empty(Shape{rows}, v.dtype());
  dispatch_float(v.dtype(), "normalize", [&](auto tag) {
    using T = decltype(tag);
    const T* pv = v.data<T>();
    T* po = out.data<T>();
    T* pd = denom.data<T>();
    // out[r, :] = v[r, :] / max(|v[r]|, eps) (see normalized()).
    parallel_for(0, rows, row_grain(k), [&](std::int64_t lo, std::int64_t hi) {
      if (k == 3) {
        normalize_rows3(pv + 3 * lo, po + 3 * lo, pd + lo, hi - lo, eps);
        return;
      }
      for (std::int64_t r = lo; r < hi; ++r) {
        const Acc d = std::max<Acc>(row_length(pv + r * k, k), eps), inv_d = 1 / d;
        for (std::int64_t j = 0; j < k; ++j) po[r * k + j] = detail::normalized<T>(pv[r * k + j], d, inv_d);
        pd[r] = T(d);
      }
    });
  });
  if (should_record({v})) {
    Tensor n = out.detach();
    record("normalize", {v}, {&out}, [n, denom, k, rows, eps](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor gv = Tensor::empty(n.shape(), n.dtype());
      dispatch_float(n.dtype(), "normalize", [&](auto tag) {
        using T = decltype(tag);
        const T *pd = denom.data<T>(), *pn = n.data<T>(), *pg = g.data<T>();
        T* po = gv.data<T>();
        parallel_for(0, rows, row_grain(k), [&](std::int64_t lo, std::int64_t hi) {
          if (k == 3) {
            normalize_adjoint_rows3(pn + 3 * lo, pg + 3 * lo, pd + lo, po + 3 * lo, hi - lo, eps);
            return;
          }
          for (std::int64_t r = lo; r < hi; ++r) {
            if (pd[r] > T(eps)) {
              const Acc inv = 1 / Acc(pd[r]);
              // Unit-sphere projection: dL/dv = (g - n (n.g)) / |v|.
              Acc ng = 0;
              for (std::int64_t j = 0; j < k; ++j) ng += Acc(pn[r * k + j]) * Acc(pg[r * k + j]);
              for (std::int64_t j = 0; j < k; ++j)
                po[r * k + j] = T((Acc(pg[r * k + j]) - Acc(pn[r * k + j]) * ng) * inv);
            } else {
              // Below eps the op is v / eps: dL/dv = g / eps.
              for (std::int64_t j = 0; j < k; ++j) po[r * k + j] = T(Acc(pg[r * k + j]) / eps);
            }
          }
        });
      });
      ctx.accumulate(0, gv);
    });
  }
  detail::trace_step(detail::OpId{detail::OpKind::Normalize}, v, Tensor(), out, eps);
  return out;
}

Tensor reflect(const Tensor& i, const Tensor& n) {
  vector_pair(i, n, "reflect", "i", "n");
  // Composite: i - 2 (n.i) n; the tape differentiates the pieces.
  return i - (2.0 * dot(n, i)) * n;
}

}  // namespace gr
