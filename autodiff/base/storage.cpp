#include "autodiff/base/storage.h"

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/base/parallel.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <cstdlib>
#include <iterator>
#include <list>
#include <map>
#include <mutex>
#include <new>

namespace gr {
namespace {

constexpr std::size_t kAlignment = 64;

// Rounds a request up to a bucket: the next multiple of 64 below 4 KiB, else the
// next power-of-two quarter step (so at most 25% of a buffer is wasted).
std::size_t bucket_size(std::size_t bytes) {
  if (bytes <= 4096) return (bytes + kAlignment - 1) / kAlignment * kAlignment + (bytes == 0 ? kAlignment : 0);
  std::size_t p = 4096;
  while (p * 2 < bytes) p *= 2;
  std::size_t step = p / 4;
  return (bytes + step - 1) / step * step;
}

// The cached buffers, oldest first (`recent`), and by size (`by_size`). Among
// buffers of one size `by_size` keeps the order they were cached in (a multimap
// inserts equal keys last), and reuse takes the newest, so the oldest buffer of
// the oldest entry's size is always by_size.lower_bound(its size).
using Entry = std::pair<std::size_t, void*>;  // bytes, buffer
using Entries = std::list<Entry>;

struct Cache {
  std::mutex mutex;
  Entries recent;
  std::multimap<std::size_t, Entries::iterator> by_size;
  StorageStats stats;
  std::size_t in_use = 0;  // bytes of live and cached buffers (the memory budget's count)
};

Cache& cache() {
  // Never destroyed: tensors may outlive static destructors. Big buffers then
  // come back from malloc without fresh pages, cached or not (autodiff/base/memory.h).
  static Cache* c = (tune_malloc(), new Cache());
  return *c;
}

// Maps the whole pages of a fresh buffer of 64 KiB to 64 MiB in one call
// (MADV_POPULATE_WRITE, Linux 5.14) instead of one page fault per page at its
// first write: an iteration 0 writes every buffer it allocates, and on a
// virtual machine a fault costs several microseconds (docs/performance.md).
// Pages already mapped (memory malloc reuses) are left as they are; an older
// kernel refuses the call and the pages fault in as before. Larger buffers are
// left to fault in as written (one that is never filled takes no memory),
// unless `filled` says the caller writes them whole now (Tensor::zeros: a
// 2048 x 2048 x 3 texture's mip-level gradient sums are 128 MiB); those are
// mapped in 8 MiB pieces in parallel, as the threads would fault them in.
void populate(void* p, std::size_t bytes, bool filled) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::size_t kMinBytes = std::size_t(64) << 10, kMaxBytes = std::size_t(64) << 20;
  constexpr std::int64_t kPiece = std::int64_t(8) << 20;  // a multiple of the page size
  if (bytes < kMinBytes || (bytes > kMaxBytes && !filled)) return;
  static const std::uintptr_t page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(p) + page - 1) / page * page;
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(p) + bytes) / page * page;
  if (end <= begin) return;
  const std::int64_t span = static_cast<std::int64_t>(end - begin);
  if (span <= kPiece) {
    madvise(reinterpret_cast<void*>(begin), end - begin, MADV_POPULATE_WRITE);
    return;
  }
  parallel_for(0, (span + kPiece - 1) / kPiece, 1, [&](std::int64_t i0, std::int64_t i1) {
    const std::uintptr_t lo = begin + static_cast<std::uintptr_t>(i0 * kPiece);
    const std::uintptr_t hi = std::min(end, begin + static_cast<std::uintptr_t>(i1 * kPiece));
    madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_POPULATE_WRITE);
  });
#else
  (void)p, (void)bytes, (void)filled;
#endif
}

// Takes a cached buffer of exactly `bytes` out of the cache (c.mutex held), or null.
void* take_cached_locked(Cache& c, std::size_t bytes) {
  const auto end = c.by_size.upper_bound(bytes);
  if (end == c.by_size.begin() || std::prev(end)->first != bytes) return nullptr;
  const auto it = std::prev(end);  // the newest of its size: likely still in the CPU's caches
  void* p = it->second->second;
  c.recent.erase(it->second);
  c.by_size.erase(it);
  c.stats.cached_bytes -= static_cast<std::int64_t>(bytes);
  return p;
}

// Moves the buffer cached longest ago out of the cache and out of the budget's
// count into `out` (c.mutex held; a splice, so no allocation in ~Storage).
void evict_oldest_locked(Cache& c, Entries& out) {
  const std::size_t bytes = c.recent.front().first;
  const auto it = c.by_size.lower_bound(bytes);
  assert(it->second == c.recent.begin());
  c.by_size.erase(it);
  out.splice(out.end(), c.recent, c.recent.begin());
  c.stats.cached_bytes -= static_cast<std::int64_t>(bytes);
  c.in_use -= bytes;
}

void evict_all_locked(Cache& c, Entries& out) {
  while (!c.recent.empty()) evict_oldest_locked(c, out);
}

// Frees evicted buffers (after unlocking: freeing a large one unmaps it).
void free_all(const Entries& evicted) {
  for (const Entry& e : evicted) std::free(e.second);
}

// Counts `bytes` against the memory budget, giving the cached buffers back
// first when that makes room. Checking and counting under one lock keeps two
// threads from both passing the check with room for one.
void reserve(Cache& c, std::size_t bytes) {
  const std::size_t limit = memory_limit();
  auto fits = [&] { return bytes <= limit && c.in_use <= limit - bytes; };
  Entries released;
  std::size_t used = 0;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    if (!fits()) evict_all_locked(c, released);
    used = c.in_use;
    if (fits()) c.in_use += bytes;
  }
  free_all(released);
  if (bytes > limit || used > limit - bytes) throw detail::memory_limit_error(bytes, "a tensor buffer", used, limit);
}

// Adds `delta` to the live bytes and raises the peak (c.mutex held).
void count_live(Cache& c, std::int64_t delta) {
  c.stats.live_bytes += delta;
  c.stats.peak_live_bytes = std::max(c.stats.peak_live_bytes, c.stats.live_bytes);
}

void unreserve(Cache& c, std::size_t bytes) {
  std::lock_guard<std::mutex> lock(c.mutex);
  c.in_use -= bytes;
}

}  // namespace

Storage::Storage(std::size_t bytes, bool filled) {
  // Refuse before rounding to a bucket: a request near SIZE_MAX cannot be rounded.
  if (bytes > memory_limit())
    throw detail::memory_limit_error(bytes, "a tensor buffer", memory_in_use(), memory_limit());
  bytes_ = bucket_size(bytes);
  Cache& c = cache();
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    ptr_ = take_cached_locked(c, bytes_);
    if (ptr_) {
      c.stats.reused++;
      count_live(c, static_cast<std::int64_t>(bytes_));
      return;
    }
  }
  reserve(c, bytes_);
  ptr_ = std::aligned_alloc(kAlignment, bytes_);
  if (!ptr_) {  // the system refused (overcommit off, ulimit): retry without the cache
    release_cached_storage();
    ptr_ = std::aligned_alloc(kAlignment, bytes_);
  }
  if (!ptr_) {
    unreserve(c, bytes_);
    throw MemoryError("a tensor buffer of " + std::to_string(bytes_) + " bytes: the system refused the allocation");
  }
  populate(ptr_, bytes_, filled);
  std::lock_guard<std::mutex> lock(c.mutex);
  c.stats.fresh_allocations++;
  count_live(c, static_cast<std::int64_t>(bytes_));
}

Storage::~Storage() {
  Cache& c = cache();
  const std::size_t cap = storage_cache_limit();
  const bool kept = bytes_ <= cap;
  Entries evicted;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    count_live(c, -static_cast<std::int64_t>(bytes_));
    // Room under the cap (which follows the memory limit): the buffers cached longest ago go first.
    while (static_cast<std::size_t>(c.stats.cached_bytes) + (kept ? bytes_ : 0) > cap) evict_oldest_locked(c, evicted);
    if (kept) {
      c.by_size.emplace(bytes_, c.recent.emplace(c.recent.end(), bytes_, ptr_));
      c.stats.cached_bytes += static_cast<std::int64_t>(bytes_);
    } else {
      c.in_use -= bytes_;
    }
  }
  free_all(evicted);
  if (!kept) std::free(ptr_);
}

StorageStats storage_stats() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.stats;
}

void reset_storage_peak() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  c.stats.peak_live_bytes = c.stats.live_bytes;
}

std::size_t storage_cache_limit() { return memory_limit() / 4; }

void release_cached_storage() {
  Cache& c = cache();
  Entries evicted;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    evict_all_locked(c, evicted);
  }
  free_all(evicted);
#if defined(__GLIBC__)
  if (tune_malloc()) malloc_trim(0);  // the tuned heap keeps freed memory: give it back too
#endif
}

std::size_t memory_in_use() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.in_use;
}

}  // namespace gr
