// STREAM-style memory bandwidth (McCalpin's copy, scale and triad) through the
// project's one threading wrapper, at 1 and 2 threads: the roof that the
// memory-bound kernels' "of_peak" columns are measured against.
#include <benchmark/benchmark.h>

#include <vector>

#include "autodiff/base/parallel.h"

namespace {

constexpr std::int64_t kElements = std::int64_t(1) << 24;  // 128 MiB per array

enum class Kernel { Copy, Scale, Triad };

template <Kernel kernel>
void BM_Stream(benchmark::State& state) {
  gr::set_num_threads(static_cast<int>(state.range(0)));
  std::vector<double> a(kElements, 0.0), b(kElements, 1.0), c(kElements, 2.0);
  const double s = 3.0;
  auto run = [&](std::int64_t lo, std::int64_t hi) {
    switch (kernel) {
      case Kernel::Copy:
        for (std::int64_t i = lo; i < hi; ++i) c[i] = a[i];
        break;
      case Kernel::Scale:
        for (std::int64_t i = lo; i < hi; ++i) b[i] = s * c[i];
        break;
      case Kernel::Triad:
        for (std::int64_t i = lo; i < hi; ++i) a[i] = b[i] + s * c[i];
        break;
    }
  };
  for (auto _ : state) {
    gr::parallel_for(0, kElements, gr::kElementwiseGrain, run);
    benchmark::ClobberMemory();
  }
  const double arrays = kernel == Kernel::Triad ? 3 : 2;  // STREAM's byte counts
  state.counters["GB/s"] =
      benchmark::Counter(arrays * sizeof(double) * kElements * state.iterations() / 1e9, benchmark::Counter::kIsRate);
  gr::set_num_threads(0);
}

}  // namespace

BENCHMARK_TEMPLATE(BM_Stream, Kernel::Copy)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_Stream, Kernel::Scale)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_Stream, Kernel::Triad)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
