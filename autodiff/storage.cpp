#include "autodiff/storage.h"

#include "autodiff/error.h"
#include "autodiff/memory.h"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <mutex>
#include <new>
#include <vector>

namespace gr {
namespace {

constexpr std::size_t kAlignment = 64;
// Buffers larger than this are not cached: holding on to them would pin memory
// that the rest of the program may need.
constexpr std::size_t kMaxCachedBuffer = std::size_t(1) << 31;
constexpr std::size_t kMaxCachedTotal = std::size_t(4) << 30;

// Rounds a request up to a bucket: the next multiple of 64 below 4 KiB, else the
// next power-of-two quarter step (so at most 25% of a buffer is wasted).
std::size_t bucket_size(std::size_t bytes) {
  if (bytes <= 4096) return (bytes + kAlignment - 1) / kAlignment * kAlignment + (bytes == 0 ? kAlignment : 0);
  std::size_t p = 4096;
  while (p * 2 < bytes) p *= 2;
  std::size_t step = p / 4;
  return (bytes + step - 1) / step * step;
}

struct Cache {
  std::mutex mutex;
  std::multimap<std::size_t, void*> free_buffers;
  StorageStats stats;
  std::size_t in_use = 0;  // bytes of live and cached buffers (the memory budget's count)
};

Cache& cache() {
  static Cache* c = new Cache();  // never destroyed: tensors may outlive static destructors
  return *c;
}

// Empties the cache (c.mutex held) and returns its buffers, to be freed after unlocking.
std::vector<void*> take_cached_locked(Cache& c) {
  std::vector<void*> taken;
  for (auto& kv : c.free_buffers) taken.push_back(kv.second);
  c.free_buffers.clear();
  c.in_use -= static_cast<std::size_t>(c.stats.cached_bytes);
  c.stats.cached_bytes = 0;
  return taken;
}

// Counts `bytes` against the memory budget, giving the cached buffers back
// first when that makes room. Checking and counting under one lock keeps two
// threads from both passing the check with room for one.
void reserve(Cache& c, std::size_t bytes) {
  const std::size_t limit = memory_limit();
  auto fits = [&] { return bytes <= limit && c.in_use <= limit - bytes; };
  std::vector<void*> released;
  std::size_t used = 0;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    if (!fits()) released = take_cached_locked(c);
    used = c.in_use;
    if (fits()) c.in_use += bytes;
  }
  for (void* p : released) std::free(p);
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

Storage::Storage(std::size_t bytes) {
  // Refuse before rounding to a bucket: a request near SIZE_MAX cannot be rounded.
  if (bytes > memory_limit())
    throw detail::memory_limit_error(bytes, "a tensor buffer", memory_in_use(), memory_limit());
  bytes_ = bucket_size(bytes);
  Cache& c = cache();
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    auto it = c.free_buffers.find(bytes_);
    if (it != c.free_buffers.end()) {
      ptr_ = it->second;
      c.free_buffers.erase(it);
      c.stats.reused++;
      c.stats.cached_bytes -= static_cast<std::int64_t>(bytes_);
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
  std::lock_guard<std::mutex> lock(c.mutex);
  c.stats.fresh_allocations++;
  count_live(c, static_cast<std::int64_t>(bytes_));
}

Storage::~Storage() {
  Cache& c = cache();
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    count_live(c, -static_cast<std::int64_t>(bytes_));
    const bool cacheable = bytes_ <= kMaxCachedBuffer && c.stats.cached_bytes + static_cast<std::int64_t>(bytes_) <=
                                                         static_cast<std::int64_t>(kMaxCachedTotal);
    if (cacheable) {
      c.free_buffers.emplace(bytes_, ptr_);
      c.stats.cached_bytes += static_cast<std::int64_t>(bytes_);
      return;
    }
  }
  unreserve(c, bytes_);
  std::free(ptr_);
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

void release_cached_storage() {
  Cache& c = cache();
  std::vector<void*> to_free;
  {
    std::lock_guard<std::mutex> lock(c.mutex);
    to_free = take_cached_locked(c);
  }
  for (void* p : to_free) std::free(p);
}

std::size_t memory_in_use() {
  Cache& c = cache();
  std::lock_guard<std::mutex> lock(c.mutex);
  return c.in_use;
}

}  // namespace gr
