// FusionTrace (ops/tensor/fusion_trace.h): while one is active on a thread, the ops
// the fused interpreter replays note each call there and nowhere else.
#include <catch2/catch.hpp>

#include <thread>

#include "ops/tensor/fusion_trace.h"
#include "ops/ops.h"

using namespace gr;
using detail::OpId;
using detail::OpKind;
using detail::op_id;
using detail::FusionTrace;

TEST_CASE("fusion trace: a replayable op notes its op, operands, result and parameter", "[ops][fused]") {
  const Tensor x = Tensor::full({4, 3}, 2.0), y = Tensor::full({3}, 0.5);
  FusionTrace trace;
  const Tensor sum = x + y, powered = pow(sum, 3.0), unit = normalize(powered, 1e-6);
  REQUIRE(trace.steps.size() == 3);
  CHECK(trace.steps[0].op == op_id<detail::AddOp>());
  CHECK(trace.steps[0].a.same(x));
  CHECK(trace.steps[0].b.same(y));
  CHECK(trace.steps[0].out.same(sum));
  CHECK(trace.steps[1].op == OpId{OpKind::Power});
  CHECK(trace.steps[1].param == 3.0);
  CHECK_FALSE(trace.steps[1].b.defined());
  CHECK(trace.steps[2].op == OpId{OpKind::Normalize});
  CHECK(trace.steps[2].param == 1e-6);
  CHECK(trace.steps[2].out.same(unit));
}

TEST_CASE("fusion trace: other ops, ops before the trace and ops on other threads are not noted", "[ops][fused]") {
  const Tensor x = Tensor::full({4, 3}, 2.0);
  const Tensor before = x * 2.0;
  FusionTrace trace;
  const Tensor e = sum(x);
  std::thread([&] { const Tensor elsewhere = x - 1.0; }).join();
  CHECK(trace.steps.empty());
  (void)before, (void)e;
}

TEST_CASE("fusion trace: an inner trace takes the ops of its lifetime, then the outer one resumes", "[ops][fused]") {
  const Tensor x = Tensor::full({4, 3}, 2.0);
  FusionTrace outer;
  const Tensor a = x * 3.0;
  {
    FusionTrace inner;
    const Tensor b = -a;
    REQUIRE(inner.steps.size() == 1);
    CHECK(inner.steps[0].op == op_id<detail::NegOp>());
  }
  const Tensor c = dot(a, x);
  REQUIRE(outer.steps.size() == 2);
  CHECK(outer.steps[0].op == op_id<detail::MulOp>());
  CHECK(outer.steps[1].op == OpId{OpKind::Dot});
  CHECK(outer.steps[1].out.same(c));
}
