// Elementwise ops on 1,048,576 elements (float32 and float64): forward, and
// forward + backward through a sum.
#include <benchmark/benchmark.h>

#include "ops/ops.h"

namespace {

constexpr std::int64_t kN = 1 << 20;

template <gr::DType D, class Op>
void run_forward(benchmark::State& state, Op op) {
  gr::Tensor a = gr::Tensor::uniform({kN}, 0.1, 1, 1, D);
  gr::Tensor b = gr::Tensor::uniform({kN}, 0.1, 1, 2, D);
  for (auto _ : state) benchmark::DoNotOptimize(op(a, b).impl());
  state.SetItemsProcessed(state.iterations() * kN);
  state.SetBytesProcessed(state.iterations() * kN * 3 * gr::dtype_size(D));
}

template <gr::DType D, class Op>
void run_backward(benchmark::State& state, Op op) {
  gr::Tensor a = gr::Tensor::uniform({kN}, 0.1, 1, 1, D).set_requires_grad();
  gr::Tensor b = gr::Tensor::uniform({kN}, 0.1, 1, 2, D).set_requires_grad();
  for (auto _ : state) {
    gr::backward(gr::sum(op(a, b)));
    a.zero_grad();
    b.zero_grad();
  }
  state.SetItemsProcessed(state.iterations() * kN);
}

auto mul_op = [](const gr::Tensor& a, const gr::Tensor& b) { return a * b; };
auto div_op = [](const gr::Tensor& a, const gr::Tensor& b) { return a / b; };
auto exp_op = [](const gr::Tensor& a, const gr::Tensor&) { return gr::exp(a); };
auto pow32_op = [](const gr::Tensor& a, const gr::Tensor&) { return gr::pow(a, 32.0); };
auto max_op = [](const gr::Tensor& a, const gr::Tensor& b) { return gr::maximum(a, b); };

template <gr::DType D> void BM_Mul(benchmark::State& s) { run_forward<D>(s, mul_op); }
template <gr::DType D> void BM_Div(benchmark::State& s) { run_forward<D>(s, div_op); }
template <gr::DType D> void BM_Exp(benchmark::State& s) { run_forward<D>(s, exp_op); }
template <gr::DType D> void BM_Pow32(benchmark::State& s) { run_forward<D>(s, pow32_op); }
template <gr::DType D> void BM_Max(benchmark::State& s) { run_forward<D>(s, max_op); }
template <gr::DType D> void BM_MulBackward(benchmark::State& s) { run_backward<D>(s, mul_op); }
template <gr::DType D> void BM_Pow32Backward(benchmark::State& s) { run_backward<D>(s, pow32_op); }

}  // namespace

#define GR_BENCH_BOTH(fn)                                                                   \
  BENCHMARK_TEMPLATE(fn, gr::DType::Float32)->Unit(benchmark::kMicrosecond)->UseRealTime(); \
  BENCHMARK_TEMPLATE(fn, gr::DType::Float64)->Unit(benchmark::kMicrosecond)->UseRealTime()
GR_BENCH_BOTH(BM_Mul);
GR_BENCH_BOTH(BM_Div);
GR_BENCH_BOTH(BM_Exp);
GR_BENCH_BOTH(BM_Pow32);
GR_BENCH_BOTH(BM_Max);
GR_BENCH_BOTH(BM_MulBackward);
GR_BENCH_BOTH(BM_Pow32Backward);

BENCHMARK_MAIN();
