// The grain rule of parallel_for: about four chunks per thread, never longer
// than the caller's grain nor shorter than a quarter of it; a range of at
// most one grain runs inline. Counts only, no timings.
#include <catch2/catch.hpp>

#include <algorithm>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "autodiff/base/parallel.h"

using namespace gr;

namespace {

// The sub-ranges one parallel_for hands its body on `threads` threads, sorted.
std::vector<std::pair<std::int64_t, std::int64_t>> chunks_of(std::int64_t n, std::int64_t grain, int threads) {
  set_num_threads(threads);
  std::mutex m;
  std::vector<std::pair<std::int64_t, std::int64_t>> seen;
  parallel_for(0, n, grain, [&](std::int64_t lo, std::int64_t hi) {
    std::lock_guard<std::mutex> lock(m);
    seen.emplace_back(lo, hi);
  });
  set_num_threads(0);
  std::sort(seen.begin(), seen.end());
  return seen;
}

}  // namespace

TEST_CASE("parallel: the grain rule asks for four chunks per thread, within a quarter grain and a grain",
          "[autodiff][parallel]") {
  // A 256 x 256 single-channel image: 8 chunks on 2 threads (it was 4), 16 on 16.
  CHECK(parallel_chunk(65536, kElementwiseGrain, 2) == 8192);
  CHECK(parallel_chunk(65536, kElementwiseGrain, 16) == 4096);
  // 256 x 256 x 4: capped at the grain on 2 threads, a quarter grain on 16.
  CHECK(parallel_chunk(262144, kElementwiseGrain, 2) == 16384);
  CHECK(parallel_chunk(262144, kElementwiseGrain, 16) == 4096);
  // Just above one grain: quarter-grain chunks, not eight tiny ones.
  CHECK(parallel_chunk(20000, kElementwiseGrain, 2) == 4096);
  // Loops of heavy items (grain 1) keep one item per chunk; with grain 5 a chunk has at least 2.
  CHECK(parallel_chunk(1000, 1, 2) == 1);
  CHECK(parallel_chunk(100, 5, 64) == 2);
  // Adam's grain (2048) over the fit's two 2562 x 3 parameters.
  CHECK(parallel_chunk(15372, 2048, 2) == 1922);
  // No thread count below one.
  CHECK(parallel_chunk(65536, kElementwiseGrain, 0) == parallel_chunk(65536, kElementwiseGrain, 1));
}

TEST_CASE("parallel: a 256 x 256 elementwise loop runs in at least four chunks per thread, each within the rule",
          "[autodiff][parallel]") {
  for (int threads : {2, 8}) {
    INFO(threads << " threads");
    const std::int64_t n = 65536, chunk = parallel_chunk(n, kElementwiseGrain, threads);
    const auto seen = chunks_of(n, kElementwiseGrain, threads);
    CHECK(std::int64_t(seen.size()) >= std::min<std::int64_t>(4 * threads, n / chunk));
    std::int64_t next = 0;  // disjoint, in order, covering [0, n)
    for (const auto& [lo, hi] : seen) {
      CHECK(lo == next);
      CHECK(hi - lo <= chunk);
      CHECK(hi - lo > chunk / 2);
      next = hi;
    }
    CHECK(next == n);
  }
}

TEST_CASE("parallel: a range of at most one grain runs as one call on the calling thread", "[autodiff][parallel]") {
  set_num_threads(8);
  std::vector<std::thread::id> callers;
  std::vector<std::pair<std::int64_t, std::int64_t>> ranges;
  parallel_for(3, 3 + kElementwiseGrain, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    callers.push_back(std::this_thread::get_id());
    ranges.emplace_back(lo, hi);
  });
  set_num_threads(0);
  REQUIRE(ranges.size() == 1);
  CHECK(ranges[0] == std::make_pair<std::int64_t, std::int64_t>(3, 3 + kElementwiseGrain));
  CHECK(callers[0] == std::this_thread::get_id());
}
