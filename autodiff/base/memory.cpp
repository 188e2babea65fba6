#include "autodiff/base/memory.h"

#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "autodiff/base/error.h"
#include "autodiff/base/storage.h"

namespace gr {
namespace {

std::atomic<std::size_t> g_limit{0};  // 0: the default, not computed yet

std::string mib(std::size_t bytes) {
  if (bytes < (std::size_t(1) << 20)) return std::to_string(bytes) + " bytes";
  return std::to_string((bytes >> 20) + ((bytes & ((std::size_t(1) << 20) - 1)) != 0)) + " MiB";
}

std::size_t physical_memory() {
  long pages = sysconf(_SC_PHYS_PAGES);
  long page = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return std::size_t(8) << 30;
  return static_cast<std::size_t>(pages) * static_cast<std::size_t>(page);
}

// Read when the limit is first needed and on set_memory_limit(0), so a
// malformed variable is reported (ValueError) every time it would be used.
std::size_t default_limit() {
  const char* env = std::getenv("GRADRASTER_MEMORY_LIMIT");
  if (env && *env) return parse_memory_size(env, "GRADRASTER_MEMORY_LIMIT");
  return physical_memory() / 4 * 3;
}

}  // namespace

std::size_t parse_memory_size(const std::string& text, const std::string& what) {
  const std::string shown = text.size() > 40 ? text.substr(0, 40) + "..." : text;
  auto bad = [&](const std::string& why) {
    return ValueError(what + ": '" + shown + "' is not a memory size (" + why +
                      "; write bytes, or a number with K, M, G or T)");
  };
  std::size_t i = 0;
  unsigned long long value = 0;
  if (text.empty() || text[0] < '0' || text[0] > '9') throw bad("no number");
  for (; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i) {
    if (value > (std::numeric_limits<unsigned long long>::max() - 9) / 10) throw bad("too large");
    value = value * 10 + static_cast<unsigned>(text[i] - '0');
  }
  int shift = 0;
  if (i < text.size()) {
    switch (text[i]) {
      case 'K': case 'k': shift = 10; break;
      case 'M': case 'm': shift = 20; break;
      case 'G': case 'g': shift = 30; break;
      case 'T': case 't': shift = 40; break;
      default: throw bad("unknown suffix");
    }
    ++i;
  }
  const std::string unit = text.substr(i);  // "8G", "8GB" and "8GiB" are all 8 * 2^30
  if (!(unit.empty() || (shift && (unit == "B" || unit == "b" || unit == "iB" || unit == "ib"))))
    throw bad("trailing characters");
  if (shift && value > (std::numeric_limits<std::size_t>::max() >> shift)) throw bad("too large");
  if (value == 0) throw bad("zero");
  return static_cast<std::size_t>(value) << shift;
}

std::size_t memory_limit() {
  std::size_t limit = g_limit.load(std::memory_order_relaxed);
  if (limit == 0) {  // two threads may both compute it: same value
    limit = default_limit();
    g_limit.store(limit, std::memory_order_relaxed);
  }
  return limit;
}

void set_memory_limit(std::size_t bytes) {
  g_limit.store(bytes ? bytes : default_limit(), std::memory_order_relaxed);
}

MemoryError detail::memory_limit_error(std::size_t bytes, const std::string& what, std::size_t used,
                                       std::size_t limit) {
  return MemoryError(what + " needs " + mib(bytes) + ", but the memory limit is " + mib(limit) + " (" + mib(used) +
                     " in use); raise it with GRADRASTER_MEMORY_LIMIT or gr::set_memory_limit() if the machine "
                     "has the memory");
}

void detail::throw_allocation_failure(const std::string& what) {
  release_cached_storage();
  throw MemoryError(what + ": the system refused to allocate scratch memory (" + mib(memory_in_use()) +
                    " of tensor storage in use, memory limit " + mib(memory_limit()) +
                    "); make the request smaller or free memory");
}

bool tune_malloc() {
  static const bool applied = [] {  // once per process; thread-safe (a function-local static)
#if defined(__GLIBC__)
    const char* defaults = std::getenv("GRADRASTER_MALLOC_DEFAULTS");
    if (defaults && std::strcmp(defaults, "1") == 0) return false;
    const int keep = static_cast<int>(std::clamp(physical_memory() / 16, std::size_t(32) << 20, std::size_t(1) << 30));
    // Older glibc refuses a threshold above 32 MiB (HEAP_MAX_SIZE / 2): then no block is mapped.
    const bool from_heap = mallopt(M_MMAP_THRESHOLD, keep) == 1 || mallopt(M_MMAP_MAX, 0) == 1;
    return mallopt(M_TRIM_THRESHOLD, keep) == 1 && from_heap;
#else
    return false;
#endif
  }();
  return applied;
}

void check_memory_request(std::size_t bytes, const std::string& what) {
  const std::size_t limit = memory_limit();
  const std::size_t used = memory_in_use();
  if (bytes > limit || used > limit - bytes) throw detail::memory_limit_error(bytes, what, used, limit);
}

}  // namespace gr
