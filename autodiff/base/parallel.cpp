// parallel_for on TBB. With set_num_threads(n > 0) every top-level loop runs
// inside a task_arena of n slots, and a global_control sets TBB's worker pool
// to n - 1 workers: an arena alone cannot get more workers than the hardware
// default (TBB ignores the request), and a global_control alone raises the pool
// but not the implicit arena's concurrency, so "8 threads" needs both.
#include "autodiff/base/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>
#include <string>

#include "autodiff/base/error.h"

// ThreadSanitizer does not see TBB's own synchronization (libtbb is not
// instrumented), so it would take every hand-over of data between the caller
// and the workers for a race. Under TSan, parallel_for states the fork/join
// order TBB guarantees: all before the call happens-before every body, every
// body happens-before the return. Bodies stay unordered with each other, so
// real races between chunks are still reported (docs/determinism.md).
#if defined(__SANITIZE_THREAD__)
#define GR_TSAN_ANNOTATIONS 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define GR_TSAN_ANNOTATIONS 1
#endif
#endif
#ifdef GR_TSAN_ANNOTATIONS
extern "C" void __tsan_acquire(void* addr);
extern "C" void __tsan_release(void* addr);
#endif

namespace gr {
namespace {

// Fork/join happens-before edges for ThreadSanitizer (no-ops otherwise).
struct ForkJoin {
#ifdef GR_TSAN_ANNOTATIONS
  char fork = 0, join = 0;
  void before_fork() { __tsan_release(&fork); }
  void body_start() { __tsan_acquire(&fork); }
  void body_end() { __tsan_release(&join); }
  void after_join() { __tsan_acquire(&join); }
#else
  void before_fork() {}
  void body_start() {}
  void body_end() {}
  void after_join() {}
#endif
};

std::mutex g_mutex;  // guards the three below
int g_threads = 0;   // 0 = TBB's default (all hardware threads)
std::unique_ptr<tbb::global_control> g_control;
// Shared so that a loop in flight keeps its arena alive if set_num_threads
// replaces it from another thread.
std::shared_ptr<tbb::task_arena> g_arena;

// > 0 while this thread runs a parallel_for body: a nested parallel_for then
// stays in the arena the thread is already working in.
thread_local int t_body_depth = 0;
// > 0 while a SerialScope is alive on this thread.
thread_local int t_serial_depth = 0;

struct BodyScope {
  explicit BodyScope(ForkJoin* sync = nullptr) : sync_(sync) {
    if (sync_) sync_->body_start();
    ++t_body_depth;
  }
  ~BodyScope() {
    --t_body_depth;
    if (sync_) sync_->body_end();
  }
  BodyScope(const BodyScope&) = delete;
  BodyScope& operator=(const BodyScope&) = delete;

 private:
  ForkJoin* sync_;
};

}  // namespace

std::int64_t parallel_chunk(std::int64_t n, std::int64_t grain, int threads) {
  grain = std::max<std::int64_t>(grain, 1);
  const std::int64_t chunks = kChunksPerThread * std::max(threads, 1);
  return std::clamp((n + chunks - 1) / chunks, (grain + kGrainSplit - 1) / kGrainSplit, grain);
}

namespace {

// parallel_for's work, split into chunks of `chunk` elements: with TBB's
// auto_partitioner (a body may get several chunks at once, fewer tasks) or,
// with `one_chunk_each`, a simple_partitioner (every body gets one chunk, so
// idle threads can take any chunk not yet started: for a few long tasks).
void run_chunks(std::int64_t begin, std::int64_t end, std::int64_t grain, bool one_chunk_each,
                const std::function<void(std::int64_t, std::int64_t)>& body) {
  if (t_serial_depth > 0) {  // a SerialScope: inline, also inside another loop's body
    BodyScope scope;
    body(begin, end);
    return;
  }
  ForkJoin sync;
  auto run = [&] {
    struct Join {  // also when a body throws
      ForkJoin& sync;
      ~Join() { sync.after_join(); }
    } join{sync};
    sync.before_fork();
    auto chunk_body = [&](const tbb::blocked_range<std::int64_t>& r) {
      BodyScope scope(&sync);
      body(r.begin(), r.end());
    };
    if (one_chunk_each) {
      tbb::parallel_for(tbb::blocked_range<std::int64_t>(begin, end, static_cast<std::size_t>(grain)), chunk_body,
                        tbb::simple_partitioner());
      return;
    }
    // The arena's thread count: the top-level one, or the outer loop's for a nested call.
    const std::int64_t chunk = parallel_chunk(end - begin, grain, tbb::this_task_arena::max_concurrency());
    tbb::parallel_for(tbb::blocked_range<std::int64_t>(begin, end, static_cast<std::size_t>(chunk)), chunk_body);
  };
  if (t_body_depth > 0) {  // nested: the current arena
    run();
    return;
  }
  std::shared_ptr<tbb::task_arena> arena;
  int threads = 0;
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    arena = g_arena;
    threads = g_threads;
  }
  if (threads == 1) {  // one thread: a plain serial loop
    BodyScope scope;
    body(begin, end);
  } else if (arena) {
    arena->execute(run);
  } else {
    run();
  }
}

}  // namespace

void parallel_for(std::int64_t begin, std::int64_t end, std::int64_t grain,
                  const std::function<void(std::int64_t, std::int64_t)>& body) {
  if (end <= begin) return;
  if (grain < 1) grain = 1;
  if (end - begin <= grain) {
    body(begin, end);
    return;
  }
  run_chunks(begin, end, grain, false, body);
}

SerialScope::SerialScope() { ++t_serial_depth; }
SerialScope::~SerialScope() { --t_serial_depth; }

void parallel_tasks(int n, const std::function<void(int)>& task) {
  if (n <= 0) return;
  // One taker per thread; each takes the next task not yet taken, so tasks
  // start in index order (a caller that puts long tasks first gets the
  // shortest tail) and no thread idles while one is left.
  std::atomic<int> next{0};
  const int takers = std::min(n, num_threads());
  run_chunks(0, takers, 1, true, [&](std::int64_t, std::int64_t) {
    for (int i = next++; i < n; i = next++) tbb::this_task_arena::isolate([&] { task(i); });
  });
}

void set_num_threads(int n) {
  if (n < 0 || n > kMaxThreads)
    throw ValueError("set_num_threads: n = " + std::to_string(n) + " is outside 0.." + std::to_string(kMaxThreads) +
                     " (0 = all hardware threads)");
  std::lock_guard<std::mutex> lock(g_mutex);
  g_arena.reset();
  g_control.reset();
  g_threads = n;
  if (g_threads == 0) return;
  // Also for n = 1: no workers at all, so a TBB loop anywhere stays serial.
  g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(g_threads));
  if (g_threads > 1) g_arena = std::make_shared<tbb::task_arena>(g_threads);
}

int num_threads() {
  std::lock_guard<std::mutex> lock(g_mutex);
  return g_threads > 0 ? g_threads : tbb::this_task_arena::max_concurrency();
}

}  // namespace gr
