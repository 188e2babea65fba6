#include "ops/tensor/broadcast.h"

#include <algorithm>
#include <array>
#include <cstring>

#include "autodiff/base/parallel.h"

namespace gr::detail {
namespace {

using Dims = std::array<std::int64_t, 4>;

// Shape left-padded with 1s to rank 4.
Dims padded(const Shape& s) {
  Dims d{1, 1, 1, 1};
  for (int i = 0; i < s.rank(); ++i) d[4 - s.rank() + i] = s[i];
  return d;
}

Dims row_major_strides(const Dims& d) {
  return {d[1] * d[2] * d[3], d[2] * d[3], d[3], 1};
}

// Offset into a tensor of dims `src` (broadcast to `dst`) of the element at
// row-major position `flat` of `dst`.
std::int64_t source_offset(std::int64_t flat, const Dims& dst, const Dims& src_strides) {
  std::int64_t off = 0;
  for (int d = 3; d >= 0; --d) {
    const std::int64_t i = flat % dst[d];
    flat /= dst[d];
    off += i * src_strides[d];
  }
  return off;
}

// Copies src (dims src_dims, broadcast) into out (dims out_dims) a row of the
// last axis at a time: each row is a plain copy or a fill.
template <class T>
void expand_kernel(const T* src, const Dims& src_dims, T* out, const Dims& out_dims) {
  Dims s = row_major_strides(src_dims);
  for (int d = 0; d < 4; ++d)
    if (src_dims[d] == 1) s[d] = 0;
  const std::int64_t inner = out_dims[3];
  const std::int64_t rows = out_dims[0] * out_dims[1] * out_dims[2];
  if (rows == 0 || inner == 0) return;  // empty: [2^40, 0] must not walk 2^40 empty rows
  if (src_dims[0] * src_dims[1] * src_dims[2] * src_dims[3] == 1) {  // one value: a flat fill
    const T value = src[0];
    parallel_for(0, rows * inner, kElementwiseGrain,
                 [&](std::int64_t lo, std::int64_t hi) { std::fill(out + lo, out + hi, value); });
    return;
  }
  const std::int64_t grain = std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(inner, 1));
  parallel_for(0, rows, grain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t r = lo; r < hi; ++r) {
      const std::int64_t i2 = r % out_dims[2], i1 = (r / out_dims[2]) % out_dims[1], i0 = r / (out_dims[1] * out_dims[2]);
      const T* sp = src + i0 * s[0] + i1 * s[1] + i2 * s[2];
      T* op = out + r * inner;
      if (s[3] == 0) std::fill(op, op + inner, sp[0]);
      else std::copy(sp, sp + inner, op);
    }
  });
}

// Sum of g[base + offset(k)] for k in [lo, hi) of the reduced index space
// (dims rd, strides rs), visited in increasing k with an odometer.
template <class T>
double sum_reduced(const T* g, std::int64_t base, const Dims& rd, const Dims& rs, std::int64_t lo, std::int64_t hi) {
  Dims idx{};
  std::int64_t rest = lo, off = 0;
  for (int d = 3; d >= 0; --d) {
    idx[d] = rest % rd[d];
    rest /= rd[d];
    off += idx[d] * rs[d];
  }
  double acc = 0;
  for (std::int64_t k = lo; k < hi; ++k) {
    acc += g[base + off];
    for (int d = 3; d >= 0; --d) {  // advance the odometer
      off += rs[d];
      if (++idx[d] < rd[d]) break;
      off -= rs[d] * rd[d];
      idx[d] = 0;
    }
  }
  return acc;
}

// out[t] = sum of g over the reduced axes, for each target element t. The
// summation order depends on shapes only.
template <class T>
void reduce_kernel(const T* g, const Dims& g_dims, T* out, const Dims& t_dims) {
  const Dims gs = row_major_strides(g_dims);
  Dims kept_strides = gs, reduced_dims = g_dims;
  for (int d = 0; d < 4; ++d) {
    if (t_dims[d] == 1) kept_strides[d] = 0;  // reduced axis: target index is 0
    else reduced_dims[d] = 1;                  // kept axis: not iterated when reducing
  }
  Dims reduced_strides = gs;
  for (int d = 0; d < 4; ++d)
    if (reduced_dims[d] == 1) reduced_strides[d] = 0;
  const std::int64_t nt = t_dims[0] * t_dims[1] * t_dims[2] * t_dims[3];
  const std::int64_t nr = reduced_dims[0] * reduced_dims[1] * reduced_dims[2] * reduced_dims[3];
  if (nr == 0) {  // a sum over an empty axis is 0 (and must not divide by its extent)
    std::fill(out, out + nt, T(0));
    return;
  }

  auto sum_range = [&](std::int64_t base, std::int64_t lo, std::int64_t hi) {
    return sum_reduced(g, base, reduced_dims, reduced_strides, lo, hi);
  };
  if (nt >= 64) {  // many outputs: one thread per output, sequential sum
    parallel_for(0, nt, 16, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t t = lo; t < hi; ++t)
        out[t] = T(sum_range(source_offset(t, t_dims, kept_strides), 0, nr));
    });
  } else {  // few outputs: split each sum into fixed blocks
    for (std::int64_t t = 0; t < nt; ++t) {
      const std::int64_t base = source_offset(t, t_dims, kept_strides);
      if (nt == 1) {  // nothing kept: the whole of g, contiguous
        // Full reduction of contiguous data: plain blocked sum.
        out[t] = T(deterministic_sum<double>(nr, 4096, [&](std::int64_t lo, std::int64_t hi) {
          double acc = 0;
          for (std::int64_t k = lo; k < hi; ++k) acc += g[k];
          return acc;
        }));
      } else {
        out[t] = T(deterministic_sum<double>(nr, 4096, [&](std::int64_t lo, std::int64_t hi) { return sum_range(base, lo, hi); }));
      }
    }
  }
}

// Sets v's strides if `t` broadcasts to `out` as a full, one-element, row or
// column operand; false for any other pattern.
bool in_place_strides(const Shape& t, const Shape& out, RowView& v) {
  v.k = out.rank() == 0 ? 1 : out[-1];
  v.rows = v.k == 0 ? 0 : out.numel() / v.k;
  const bool last_is_k = t.rank() >= 1 && t[-1] == v.k;
  const bool last_is_one = t.rank() >= 1 && t[-1] == 1;
  if (t == out) {
    v.row_stride = v.k, v.col_stride = 1;
  } else if (t.numel() == 1) {
    v.row_stride = 0, v.col_stride = 0;
  } else if (last_is_k && t.numel() == v.k) {  // [1, .., 1, k]: one row, repeated
    v.row_stride = 0, v.col_stride = 1;
  } else if (last_is_one && t.numel() == v.rows) {
    // [..., 1] whose leading extents (each 1 or equal to out's) multiply to
    // rows: they all equal out's, so row r of the output reads element r.
    v.row_stride = 1, v.col_stride = 0;
  } else {
    return false;
  }
  return true;
}

}  // namespace

Shape broadcast_shapes(const Shape& a, const Shape& b, const std::string& op) {
  const int rank = a.rank() > b.rank() ? a.rank() : b.rank();
  std::vector<std::int64_t> out(static_cast<std::size_t>(rank));
  for (int i = 0; i < rank; ++i) {
    const int ia = a.rank() - rank + i, ib = b.rank() - rank + i;
    const std::int64_t da = ia >= 0 ? a[ia] : 1, db = ib >= 0 ? b[ib] : 1;
    if (da != db && da != 1 && db != 1)
      throw ShapeError(op + ": shapes " + a.str() + " and " + b.str() + " cannot be broadcast together");
    out[i] = da == 1 ? db : da;
  }
  return Shape(out);
}

Tensor expand_raw(const Tensor& t, const Shape& out) {
  if (t.numel() == 1) return t;
  return expand_raw_full(t, out);
}

Tensor expand_raw_full(const Tensor& t, const Shape& out) {
  if (t.shape() == out) return t;
  Tensor r = Tensor::empty(out, t.dtype());
  switch (t.dtype()) {
    case DType::Float32: expand_kernel(t.data<float>(), padded(t.shape()), r.data<float>(), padded(out)); break;
    case DType::Float64: expand_kernel(t.data<double>(), padded(t.shape()), r.data<double>(), padded(out)); break;
    case DType::Int32: expand_kernel(t.data<std::int32_t>(), padded(t.shape()), r.data<std::int32_t>(), padded(out)); break;
  }
  return r;
}

RowView row_view(const Tensor& t, const Shape& out) {
  RowView v;
  v.tensor = t;
  if (!in_place_strides(t.shape(), out, v)) {
    v.tensor = expand_raw_full(t, out);
    v.row_stride = v.k, v.col_stride = 1;
    v.materialized = true;
  }
  return v;
}

Tensor reduce_raw(const Tensor& g, const Shape& target) {
  if (g.shape() == target) return g;
  Tensor r = Tensor::empty(target, g.dtype());
  // A row or column broadcast: one contiguous pass, summed in the same order as
  // reduce_kernel below (except a row of 64+ elements, which it sums unblocked).
  RowView v;
  if (in_place_strides(target, g.shape(), v) && (v.row() || v.column())) {
    dispatch_float(g.dtype(), "sum", [&](auto tag) {
      using T = decltype(tag);
      const T* pg = g.data<T>();
      sum_into_operand<T>(v, [pg](std::int64_t i, std::int64_t, std::int64_t) { return pg[i]; }, r.data<T>());
    });
    return r;
  }
  dispatch_float(g.dtype(), "sum", [&](auto tag) {
    using T = decltype(tag);
    reduce_kernel(g.data<T>(), padded(g.shape()), r.data<T>(), padded(target));
  });
  return r;
}

}  // namespace gr::detail
