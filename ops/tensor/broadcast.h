// Internal helpers shared by the op implementations: broadcasting rules,
// materializing a broadcast and summing a gradient back to an operand's shape
// (the argument checks are in ops/check.h). Nothing here records on the tape.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/base/tensor.h"
#include "ops/check.h"  // the argument checks every op uses

namespace gr::detail {

// NumPy broadcast of two shapes; throws ShapeError naming the op and both shapes.
Shape broadcast_shapes(const Shape& a, const Shape& b, const std::string& op);

// `t` itself if it already has shape `out` or has one element (kernels treat
// a one-element operand as a scalar); otherwise a new tensor with t repeated
// along its broadcast axes.
Tensor expand_raw(const Tensor& t, const Shape& out);

// Like expand_raw, but one-element tensors are repeated too: the result
// always has shape `out` (t itself if it already has).
Tensor expand_raw_full(const Tensor& t, const Shape& out);

// Sums `g` over the axes along which `target` was broadcast to g's shape.
// Returns g itself when the shapes are equal. Deterministic for any thread count.
Tensor reduce_raw(const Tensor& g, const Shape& target);

// An operand of an elementwise op whose output has shape `out`, with the output
// seen as a matrix [rows, k] (k = last extent of `out`, 1 for a scalar output).
// Output position (r, j) reads tensor[r * row_stride + j * col_stride]. Full
// operands, one-element operands, a row [k] repeated over the rows and a column
// [..., 1] repeated along the last axis are read in place (no copy); any other
// broadcast is materialized with expand_raw_full and read as full.
struct RowView {
  Tensor tensor;
  std::int64_t rows = 0, k = 1;
  std::int64_t row_stride = 0, col_stride = 0;
  bool materialized = false;  // tensor is an expanded copy, not the operand itself
  bool full() const { return row_stride == k && col_stride == 1; }
  bool scalar() const { return row_stride == 0 && col_stride == 0; }
  bool row() const { return row_stride == 0 && col_stride == 1; }
  bool column() const { return row_stride == 1 && col_stride == 0; }
};
RowView row_view(const Tensor& t, const Shape& out);

// The gradient of an operand read through `v`: for each operand element, the
// sum of term(i, r, j) over the output positions (r, j) (flat index
// i = r * k + j) that read it, written to `out` (v.tensor's element count;
// a full operand gets each term itself). A term that ignores r and j
// compiles to a flat, vectorizable loop (the counters are dead code). Sums are
// accumulated in double in an order fixed by the shapes (rows in blocks of
// kSumBlock, blocks added in order), so results do not depend on the thread count.
constexpr std::int64_t kSumBlock = 4096;
template <class T, class Term>
void sum_into_operand(const RowView& v, Term term, T* out) {
  const std::int64_t rows = v.rows, k = v.k, n = rows * k;
  const std::int64_t row_grain = std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, k));
  if (v.full()) {
    parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
      std::int64_t r = lo / k, j = lo - r * k;
      for (std::int64_t i = lo; i < hi; ++i) {
        out[i] = term(i, r, j);
        if (++j == k) j = 0, ++r;
      }
    });
  } else if (v.scalar()) {
    out[0] = T(deterministic_sum<double>(n, kSumBlock, [&](std::int64_t lo, std::int64_t hi) {
      double acc = 0;
      std::int64_t r = lo / k, j = lo - r * k;
      for (std::int64_t i = lo; i < hi; ++i) {
        acc += double(term(i, r, j));
        if (++j == k) j = 0, ++r;
      }
      return acc;
    }));
  } else if (v.column()) {  // out[r] = sum_j term(r, j)
    parallel_for(0, rows, row_grain, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t r = lo; r < hi; ++r) {
        double acc = 0;
        for (std::int64_t j = 0; j < k; ++j) acc += double(term(r * k + j, r, j));
        out[r] = T(acc);
      }
    });
  } else {  // row: out[j] = sum_r term(r, j), per block of rows, blocks in order
    const std::int64_t blocks = (rows + kSumBlock - 1) / kSumBlock;
    std::vector<double> partial(static_cast<std::size_t>(blocks * k), 0.0);
    parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
      for (std::int64_t b = b0; b < b1; ++b) {
        double* acc = partial.data() + b * k;
        const std::int64_t r1 = std::min(rows, (b + 1) * kSumBlock);
        if (k == 3) {  // the same sums in registers (through memory each add waits on a store)
          double a0 = 0, a1 = 0, a2 = 0;
          for (std::int64_t r = b * kSumBlock; r < r1; ++r) {
            a0 += double(term(3 * r, r, 0));
            a1 += double(term(3 * r + 1, r, 1));
            a2 += double(term(3 * r + 2, r, 2));
          }
          acc[0] = a0, acc[1] = a1, acc[2] = a2;
          continue;
        }
        for (std::int64_t r = b * kSumBlock; r < r1; ++r)
          for (std::int64_t j = 0; j < k; ++j) acc[j] += double(term(r * k + j, r, j));
      }
    });
    for (std::int64_t j = 0; j < k; ++j) {
      double total = 0;
      for (std::int64_t b = 0; b < blocks; ++b) total += partial[static_cast<std::size_t>(b * k + j)];
      out[j] = T(total);
    }
  }
}

}  // namespace gr::detail
