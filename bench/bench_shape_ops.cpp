// slice and concat along the channel axis of [S, S, C] images, as the fit's
// shading does (concat(rgb [S,S,3], coverage [S,S,1]) -> rgba every view;
// slice rgba 0:3 and 3:4 for snapshots). Forward alone and forward + its own
// backward (from a fixed random upstream gradient).
//   Args {size, backward (0/1), threads (set_num_threads)}.
//
// Measured (2 shared cores, us, median of 4 interleaved runs of 5 repetitions
// each; before = one division per element and one parallel loop per part):
//                      256, fwd   256, fwd+bwd   512, fwd   512, fwd+bwd   (1 thread)
//   slice 0:3 of rgba  672 -> 40  1492 -> 117    2505 -> 162  5029 -> 550
//   slice 3:4 of rgba  162 -> 21   416 -> 77      647 -> 87   1678 -> 384
//   concat rgb, alpha  317 -> 58   681 -> 140    1386 -> 245  2981 -> 728
#include <benchmark/benchmark.h>

#include <functional>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"

namespace {

using namespace gr;

// Times op(), and with backward = 1 its reverse sweep too, on state.range(2) threads.
void time_op(benchmark::State& state, const std::function<Tensor()>& op) {
  const bool with_backward = state.range(1) != 0;
  set_num_threads(static_cast<int>(state.range(2)));
  Tensor upstream;
  for (auto _ : state) {
    Tensor out = op();
    if (!with_backward) {
      Tape::current().clear();
      continue;
    }
    if (!upstream.defined()) upstream = Tensor::uniform(out.shape(), -1, 1, 7, out.dtype());
    backward(out, upstream);
  }
  set_num_threads(0);
}

Tensor image(benchmark::State& state, std::int64_t channels, std::uint64_t seed) {
  const std::int64_t s = state.range(0);
  return Tensor::uniform({s, s, channels}, 0, 1, seed).set_requires_grad();
}

void BM_SliceRGB(benchmark::State& state) {
  const Tensor rgba = image(state, 4, 1);
  time_op(state, [&] { return slice(rgba, 2, 0, 3); });
}

void BM_SliceAlpha(benchmark::State& state) {
  const Tensor rgba = image(state, 4, 1);
  time_op(state, [&] { return slice(rgba, 2, 3, 4); });
}

void BM_ConcatRGBA(benchmark::State& state) {
  const Tensor rgb = image(state, 3, 2), alpha = image(state, 1, 3);
  time_op(state, [&] { return concat({rgb, alpha}, 2); });
}

void args(benchmark::internal::Benchmark* b) {
  for (int size : {256, 512})
    for (int backward : {0, 1})
      for (int threads : {1, 2}) b->Args({size, backward, threads});
  b->Unit(benchmark::kMicrosecond);
}

}  // namespace

BENCHMARK(BM_SliceRGB)->Apply(args);
BENCHMARK(BM_SliceAlpha)->Apply(args);
BENCHMARK(BM_ConcatRGBA)->Apply(args);

BENCHMARK_MAIN();
