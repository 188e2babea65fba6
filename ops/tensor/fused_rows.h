// The fused row interpreter behind map_rows (issue 17, route (b);
// docs/map_rows.md): a row-wise function traced once (ops/tensor/fusion_trace.h) is
// replayed on chunks of 256 lanes (pixels), each value held as one array per
// component that stays in cache, so a shading graph costs one pass over its
// inputs instead of a pass per op. Forward and adjoint evaluate the eager ops'
// own definitions (the elementwise op table, ops/tensor/elementwise_table.h, and the
// shared kernels of ops/tensor/elementwise_formulas.h, in the same operation order), so
// outputs and row gradients are bit-identical to the eager ops'.
//
// Replayed: every entry of the elementwise op table, pow(x, p), dot and
// normalize, on values whose axes but the last are the lanes (the pixels: [P]
// of [P, k] rows, [P, W] of an image's [P, W, k]; or [P] values, one lane per
// row), with operands that are values of the same shape, a column [..., 1]
// against [..., k], a shared or constant vector [k] against [..., k], or a
// one-element shared or constant value. A trace holding anything else
// (another op, a broadcast outside these, mixed dtypes, a captured tensor
// with rows) does not compile, and map_rows keeps calling f per block.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "autodiff/base/tensor.h"
#include "ops/tensor/fusion_trace.h"

namespace gr::detail {

class FusedRows {
 public:
  // The program of f, from its trace on one block: `rows` and `shared` are the
  // tensors f was called with (P rows each), `result` what it returned.
  // rows_grad[i] / shared_grad[j]: whether that input needs a gradient.
  // nullptr if the trace is not replayable (see above).
  static std::shared_ptr<const FusedRows> compile(const FusionTrace& trace, const std::vector<Tensor>& rows,
                                                  const std::vector<Tensor>& shared, const Tensor& result,
                                                  const std::vector<bool>& rows_grad, const std::vector<bool>& shared_grad);

  // out's rows [lo, hi) = f(rows' rows [lo, hi)).
  void forward(const std::vector<Tensor>& rows, Tensor& out, std::int64_t lo, std::int64_t hi) const;

  // Rows [lo, hi) with upstream gradient g (out's shape): writes those rows of
  // row_grads[i] (each defined one; zeros where no gradient arrives) and
  // returns the shared inputs' gradients summed over these rows (in double,
  // per lane position, then over lanes in order; undefined where not needed).
  std::vector<Tensor> backward(const std::vector<Tensor>& rows, const Tensor& g, std::vector<Tensor>& row_grads,
                               std::int64_t lo, std::int64_t hi) const;

  // The backward for an upstream gradient of `seed` in every element of the
  // result (a mean's), and, when `sums` is given, the result's sums over runs
  // of kSumBlock elements in element order, as reduce's full sum adds them
  // (the rows' first element must start a run; ceil(elements / kSumBlock) sums).
  std::vector<Tensor> backward_uniform(const std::vector<Tensor>& rows, double seed, std::vector<Tensor>& row_grads,
                                       std::int64_t lo, std::int64_t hi, double* sums = nullptr) const;

  struct Value;
  struct Operand;
  struct Instr;

 private:
  struct Compiler;  // compile's working state (fused_rows_compile.cpp)
  template <class T>
  friend class FusedEvaluator;
  std::vector<Tensor> evaluate(const std::vector<Tensor>& rows, Tensor* out, double* sums, const Tensor* g, double seed,
                               std::vector<Tensor>* row_grads, std::int64_t lo, std::int64_t hi) const;

  DType dtype_ = DType::Float32;
  std::vector<Value> values_;
  std::vector<int> row_values_, shared_values_;  // each input's value (-1: not replayable)
  std::vector<Instr> instrs_;
  std::vector<double> uniforms_;    // shared inputs' and constants' values (exact in T)
  std::vector<Shape> shared_shapes_;
  std::int64_t arena_arrays_ = 0;   // lane arrays: values, gradients, normalize's lengths
  std::int64_t partial_arrays_ = 0; // double lane arrays: shared gradients' partial sums
  int result_ = -1;
  std::int64_t lanes_per_row_ = 1;  // lanes in one row of the inputs (an image row's pixels)
};

}  // namespace gr::detail
