// What the fused row interpreter (ops/tensor/fused_rows.h) learns of a user's
// function: while a FusionTrace is active on a thread, the ops it can replay
// note each call (op, operands, result, scalar parameter) on it. The ops run
// as usual; a trace only watches. An op that does not note itself leaves a
// value the trace has never seen, which makes the function not fusable.
#pragma once

#include <vector>

#include "autodiff/base/tensor.h"
#include "ops/tensor/elementwise_table.h"

namespace gr::detail {

struct TracedStep {
  OpId op;             // an entry of the elementwise table, pow(x, p), dot or normalize
  Tensor a, b, out;    // b undefined for unary ops
  double param = 0;    // pow's exponent, normalize's eps, clamp's lower bound
  double param2 = 0;   // clamp's upper bound
};

// Active on the constructing thread for its lifetime (scopes nest).
class FusionTrace {
 public:
  FusionTrace();
  ~FusionTrace();
  FusionTrace(const FusionTrace&) = delete;
  FusionTrace& operator=(const FusionTrace&) = delete;

  std::vector<TracedStep> steps;

 private:
  FusionTrace* previous_;
};

// Called by the replayable ops after computing `out`: a no-op unless a trace
// is active on this thread.
void trace_step(OpId op, const Tensor& a, const Tensor& b, const Tensor& out, double param = 0,
                double param2 = 0);

}  // namespace gr::detail
