#include "ops/tensor/fusion_trace.h"

namespace gr::detail {
namespace {

thread_local FusionTrace* active_trace = nullptr;

}  // namespace

FusionTrace::FusionTrace() : previous_(active_trace) { active_trace = this; }

FusionTrace::~FusionTrace() { active_trace = previous_; }

void trace_step(OpId op, const Tensor& a, const Tensor& b, const Tensor& out, double param, double param2) {
  if (active_trace) active_trace->steps.push_back({op, a, b, out, param, param2});
}

}  // namespace gr::detail
