#include "roofline.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/base/storage.h"

namespace gr::bench {
namespace {

double measure_triad() {
  const std::int64_t n = std::int64_t(1) << 24;  // 3 x 128 MiB of doubles
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  auto triad = [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) a[i] = b[i] + 3.0 * c[i];
  };
  parallel_for(0, n, kElementwiseGrain, triad);  // first touch
  double best = 1e300;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    parallel_for(0, n, kElementwiseGrain, triad);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  benchmark::DoNotOptimize(a.data());
  return 24.0 * static_cast<double>(n) / best;
}

}  // namespace

double triad_bandwidth() {
  static std::map<int, double> cached;
  const int threads = num_threads();
  auto it = cached.find(threads);
  if (it == cached.end()) it = cached.emplace(threads, measure_triad()).first;
  return it->second;
}

void report_traffic(benchmark::State& state, double bytes_per_iteration) {
  const double bytes = bytes_per_iteration * static_cast<double>(state.iterations());
  state.counters["GB/s"] = benchmark::Counter(bytes / 1e9, benchmark::Counter::kIsRate);
  // of_peak = achieved rate / triad rate; the rate is only known at the end,
  // so it is stated as a rate of (bytes / peak) per second.
  state.counters["of_peak"] = benchmark::Counter(bytes / triad_bandwidth(), benchmark::Counter::kIsRate);
}

double bytes_of(const std::vector<Tensor>& tensors) {
  double bytes = 0;
  for (const Tensor& t : tensors)
    if (t.defined()) bytes += double(t.numel()) * double(dtype_size(t.dtype()));
  return bytes;
}

double grad_bytes(const std::vector<Tensor>& tensors) {
  double bytes = 0;
  for (const Tensor& t : tensors)
    if (t.defined() && t.requires_grad()) bytes += bytes_of({t});
  return bytes;
}

StoragePeak::StoragePeak() : base_(storage_stats().live_bytes) { reset_storage_peak(); }

void StoragePeak::report(benchmark::State& state, double extra_bytes) const {
  const double bytes = double(storage_stats().peak_live_bytes - base_) + extra_bytes;
  state.counters["peak_MiB"] = bytes / double(1 << 20);
}

}  // namespace gr::bench
