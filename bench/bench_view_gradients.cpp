// The cost of the order-independent gradient sum (autodiff/view_gradients.h)
// on one process: taking every view's gradients aside and summing them in
// view order, for the demo's parameter count (2562 points and colours:
// 15,372 values) and a 1M-vertex mesh (3M positions). The MPI gather adds the
// transfer of views x parameters doubles to this (docs/scaling.md).
#include <benchmark/benchmark.h>

#include "autodiff/tape.h"
#include "autodiff/view_gradients.h"

namespace {

void BM_ViewGradients(benchmark::State& state) {
  const int views = static_cast<int>(state.range(0));
  const std::int64_t params = state.range(1);
  gr::Tensor w = gr::Tensor::zeros({params}).set_requires_grad();
  const gr::Tensor g = gr::Tensor::full({params}, 0.25f);
  gr::SingleProcess alone;
  gr::ViewGradients grads({w}, views, 1);  // kept across iterations, as a fit keeps it
  auto iteration = [&] {
    for (int v = 0; v < views; ++v) {
      gr::backward(w, g);  // stands in for a view's backward pass
      grads.take(v, {1.0});
    }
    benchmark::DoNotOptimize(grads.reduce(alone));
    w.zero_grad();
  };
  iteration();  // warm-up: the first iteration pages in the buffers (seconds at 288 MB here)
  for (auto _ : state) iteration();
  state.counters["MB_gathered"] = double(views) * double(params + 2) * 8 / 1e6;
}

}  // namespace

BENCHMARK(BM_ViewGradients)
    ->ArgNames({"views", "params"})
    ->Args({6, 15372})
    ->Args({12, 15372})
    ->Args({12, 3000000})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
