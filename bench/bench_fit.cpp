// The main example's optimization loop (examples/fit, issue 31): one
// iteration of gradraster-fit's shape mode (6 views, 2562 points, vertex
// colours) at a given image size and thread count, snapshots off. Timed is the
// loop alone (FitResult's phases), not the scene set-up, so run_fit runs
// kIterations steps per benchmark iteration and reports the time per step.
//
// BM_FitStep: Args {size, threads, views}. Counters (ms per step): views (the
// concurrent render + loss + backward of every view) and rest (everything
// else: positions, normals, reduce, Laplacian, Adam). The fixed cost per step
// is the intercept of time against pixels over the sizes 64, 128, 256
// (docs/performance.md); run with --benchmark_enable_random_interleaving=true
// and repetitions to get medians of interleaved runs.
#include <benchmark/benchmark.h>

#include <sstream>

#include "autodiff/base/parallel.h"
#include "examples/fit/fit.h"

namespace {

constexpr int kIterations = 10;

void BM_FitStep(benchmark::State& state) {
  fit::FitOptions options;
  options.size = static_cast<int>(state.range(0));
  options.threads = static_cast<int>(state.range(1));
  options.views = static_cast<int>(state.range(2));
  options.iterations = kIterations;
  options.write_outputs = false;
  options.progress_bar = false;
  double views = 0, rest = 0, steps = 0;
  for (auto _ : state) {
    std::ostringstream log;
    const fit::FitResult r = fit::run_fit(options, log);
    double loop = 0;
    for (const fit::PhaseTime& p : r.phases) {
      loop += p.seconds;
      (p.name.rfind("views", 0) == 0 ? views : rest) += p.seconds;
    }
    steps += kIterations;
    state.SetIterationTime(loop / kIterations);
  }
  state.counters["views_ms"] = 1000 * views / steps;
  state.counters["rest_ms"] = 1000 * rest / steps;
  gr::set_num_threads(0);
}

}  // namespace

BENCHMARK(BM_FitStep)
    ->ArgNames({"size", "threads", "views"})
    ->ArgsProduct({{64, 128, 256}, {1, 2}, {6}})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
