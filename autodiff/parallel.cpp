#include "autodiff/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <memory>
#include <mutex>

namespace gr {
namespace {
std::mutex g_control_mutex;
std::unique_ptr<tbb::global_control> g_control;
int g_threads = 0;
}  // namespace

void parallel_for(std::int64_t begin, std::int64_t end, std::int64_t grain,
                  const std::function<void(std::int64_t, std::int64_t)>& body) {
  if (end <= begin) return;
  if (grain < 1) grain = 1;
  if (end - begin <= grain) {
    body(begin, end);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::int64_t>(begin, end, static_cast<std::size_t>(grain)),
                    [&](const tbb::blocked_range<std::int64_t>& r) { body(r.begin(), r.end()); });
}

void set_num_threads(int n) {
  std::lock_guard<std::mutex> lock(g_control_mutex);
  g_control.reset();
  g_threads = n > 0 ? n : 0;
  if (g_threads > 0)
    g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      static_cast<std::size_t>(g_threads));
}

int num_threads() {
  std::lock_guard<std::mutex> lock(g_control_mutex);
  return g_threads > 0 ? g_threads : tbb::this_task_arena::max_concurrency();
}

}  // namespace gr
