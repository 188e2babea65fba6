// The one threading wrapper: every parallel loop in gradraster goes through
// here, and this is the only header that knows TBB exists.
//
// Results never depend on the thread count: parallel_for bodies write disjoint
// outputs, and deterministic_sum splits work into fixed blocks whose partial
// sums are added in block order.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace gr {

// Default grain of cheap elementwise loops: a range this short is not worth
// waking other threads for (a launch costs about 7 us, a wake-up 14 us).
constexpr std::int64_t kElementwiseGrain = 16384;

// Runs body(lo, hi) over disjoint sub-ranges covering [begin, end). Ranges of
// at most `grain` elements run inline on the calling thread, and so does
// everything with one thread. Longer ranges run in chunks of about
// parallel_chunk(n, grain, threads) elements. A parallel_for inside a body is
// allowed (it shares the outer loop's threads).
void parallel_for(std::int64_t begin, std::int64_t end, std::int64_t grain,
                  const std::function<void(std::int64_t, std::int64_t)>& body);

// The grain rule: about kChunksPerThread chunks per thread, so a worker that
// wakes late or an uneven chunk costs little, but never chunks longer than
// `grain` nor shorter than grain / kGrainSplit (each chunk is a task, about
// 1 us; for kElementwiseGrain that is at least 4096 elements):
//   chunk = clamp(ceil(n / (kChunksPerThread threads)), ceil(grain / kGrainSplit), grain).
// A 256 x 256 image (n = 65536) of an elementwise op gets 8 chunks of 8192 on
// 2 threads and 16 of 4096 on 16; with grain 16384 alone it got 4.
// parallel_for splits a range in halves until the pieces are at most `chunk`
// long. Chunking never changes results: bodies write disjoint outputs, and
// deterministic_sum's blocks do not depend on it.
constexpr std::int64_t kChunksPerThread = 4;
constexpr std::int64_t kGrainSplit = 4;
std::int64_t parallel_chunk(std::int64_t n, std::int64_t grain, int threads);

// Runs task(i) for every i in [0, n), concurrently where threads are free:
// each thread takes the next task not yet started, in order i = 0, 1, ...
// (so put the longest first for the shortest tail). Each task is isolated: while it
// waits for its own inner parallel_for, its thread helps only with that loop,
// never starts another task, so thread-local state a task sets up (a
// ScopedTape, a NoGradGuard) is seen by that task alone. For a few large
// independent jobs, such as the views of one optimization step.
void parallel_tasks(int n, const std::function<void(int)>& task);

// While alive, every parallel_for this thread starts runs inline on it, as
// with one thread. For a background thread (a file writer) that must not take
// a slot among the workers the foreground's loops share. Nests; per thread.
class SerialScope {
 public:
  SerialScope();
  ~SerialScope();
  SerialScope(const SerialScope&) = delete;
  SerialScope& operator=(const SerialScope&) = delete;
};

// Largest n set_num_threads accepts.
constexpr int kMaxThreads = 1024;

// Runs every later parallel_for on up to n threads (0 = all hardware
// threads, the default), also more than the machine has cores: n = 8 on two
// cores really starts 8 threads (useful to test determinism and races).
// n < 0 or n > kMaxThreads throws ValueError (the setting is unchanged).
// Call it between parallel regions, not from inside a parallel_for body.
void set_num_threads(int n);
// The n of set_num_threads, or the hardware thread count for 0.
int num_threads();

// Sum over [0, n) of block_sum(lo, hi), with blocks of `block` elements fixed
// by n alone, so the result is bit-identical for any thread count.
template <class Acc, class BlockSum>
Acc deterministic_sum(std::int64_t n, std::int64_t block, BlockSum block_sum) {
  const std::int64_t blocks = (n + block - 1) / block;
  std::vector<Acc> partial(static_cast<std::size_t>(blocks), Acc(0));
  parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b)
      partial[b] = block_sum(b * block, b * block + block < n ? b * block + block : n);
  });
  Acc total(0);
  for (const Acc& p : partial) total += p;
  return total;
}

}  // namespace gr
