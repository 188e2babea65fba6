// The program the fused row interpreter runs (ops/tensor/fused_rows.h): its values,
// operands and instructions, as FusedRows::compile (ops/tensor/fused_rows_compile.cpp)
// builds them and the evaluator (ops/tensor/fused_rows.cpp) reads them. Internal.
#pragma once

#include <cstdint>

#include "ops/tensor/fused_rows.h"

namespace gr::detail {

inline constexpr std::int64_t kLanes = 256;        // lanes (pixels) per chunk: a value's component is 1 KiB (float32)
inline constexpr std::int64_t kMaxConstant = 64;   // elements of a tensor f captured that is taken as a constant
inline constexpr std::int64_t kMaxArenaBytes = std::int64_t(16) << 20;  // wider rows than this allows run per block


struct FusedRows::Value {
  bool varying = false;     // one value per lane; else one for every lane (a shared input or a constant)
  int rank = 0;             // varying: 1 ([P], no last axis) or 2 ([P, ..., width]: the lanes' shape, then width)
  int width = 1;            // components
  std::int64_t array = -1;  // varying: its first lane array; uniform: its first element in uniforms_
  bool produced = false;    // the result of an instruction
  bool needs_grad = false;  // depends on an input that needs a gradient
  bool live = false;        // the result depends on it
  std::int64_t grad = -1;   // varying: first gradient lane array; shared: first partial-sum array
  std::int64_t aux = -1;    // normalize's result: the lane array of its lengths max(|v|, eps)
};

struct FusedRows::Operand {
  int value = -1;
  bool spread = false;  // its one component is read by every component (a column or a scalar)
};

struct FusedRows::Instr {
  OpId op;
  Operand a, b;             // b.value == -1 for unary ops
  int out = -1;
  int components = 1;       // components the operands are read at (dot: the vectors' length)
  double param = 0;         // pow's exponent, normalize's eps, clamp's lower bound
  double param2 = 0;        // clamp's upper bound
  bool a_first = false, b_first = false;  // the operand's first gradient contribution: assigned, not added
  bool negate_b = false;    // b's gradient is the negated sum of g (sub; negates_b)
  bool backward = false;    // its result receives a gradient
};

}  // namespace gr::detail
