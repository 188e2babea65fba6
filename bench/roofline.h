// The roofline columns of every kernel benchmark: the machine's measured
// memory bandwidth (a STREAM triad, as bench_stream reports it) and, per
// benchmark, the bytes it must move, the achieved GB/s and their ratio.
#pragma once

#include <benchmark/benchmark.h>

#include <cstdint>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr::bench {

// Triad bandwidth a[i] = b[i] + s c[i] over arrays far larger than the caches,
// at the current gr::num_threads(), in bytes per second (24 bytes per element:
// two reads, one write). Measured once per thread count and cached.
double triad_bandwidth();

// Adds the counters "GB/s" (bytes_per_iteration per iteration, as a rate) and
// "of_peak" (that rate over triad_bandwidth()). bytes_per_iteration is the
// compulsory traffic: every input read once and every output written once.
void report_traffic(benchmark::State& state, double bytes_per_iteration);

// Bytes of the tensors' values (undefined tensors count 0): the compulsory
// traffic of an op is bytes_of(its inputs and outputs); with its backward add
// the upstream gradient and the gradients it writes (grad_bytes).
double bytes_of(const std::vector<Tensor>& tensors);
// Bytes of the gradients of those tensors that require one.
double grad_bytes(const std::vector<Tensor>& tensors);

// Peak tensor storage of a benchmark: construct before the loop, report()
// after it. Counts what tensors hold at once (autodiff/base/storage.h's live
// bytes) above what was held at construction, plus `extra_bytes` held
// outside tensors (the fused baseline's std::vector outputs), as "peak_MiB".
class StoragePeak {
 public:
  StoragePeak();
  void report(benchmark::State& state, double extra_bytes = 0) const;

 private:
  std::int64_t base_;
};

}  // namespace gr::bench
