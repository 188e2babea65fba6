// Contiguous, 64-byte aligned element buffers shared between tensors.
//
// Buffers are recycled through a size-bucketed cache, so an optimization loop
// that builds the same graph every iteration stops allocating after the first
// iteration. `storage_stats()` counts fresh allocations so tests and benchmarks
// can verify that.
//
// The cache keeps buffers of any size (a 2048 x 2048 texture's gradient as well
// as a scalar) up to storage_cache_limit() bytes in all, a quarter of the memory
// limit (autodiff/base/memory.h): a loop whose buffers fit stops faulting in fresh
// pages, and an idle process holds at most that much for reuse. To make room
// the buffers cached longest ago go back to the system allocator first; a
// request that would pass the memory limit empties the whole cache first, and
// release_cached_storage() empties it on demand. A recycled buffer is handed
// out as it was left, never cleared (Tensor::zeros clears, Tensor::empty not).
// A fresh buffer of 64 KiB to 64 MiB has its pages mapped in one call (Linux:
// MADV_POPULATE_WRITE) rather than page-faulted in one by one as it is written;
// so does a larger one that its maker writes whole at once (Tensor::zeros,
// Tensor::full: `filled`).
//
// Each Storage counts the in-place writes made into it (its version): the
// non-const Tensor::data<T>() bumps it, the gradient tape saves it when it
// records a tensor, and backward() refuses a recorded tensor written since
// (autodiff/tape.h). A recycled buffer gets a new Storage, so a new count.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

namespace gr {

class Storage {
 public:
  // Contents uninitialized. filled: the caller writes every byte right away.
  explicit Storage(std::size_t bytes, bool filled = false);
  ~Storage();
  Storage(const Storage&) = delete;
  Storage& operator=(const Storage&) = delete;

  void* data() { return ptr_; }
  const void* data() const { return ptr_; }
  std::size_t bytes() const { return bytes_; }

  // Writes counted so far. Atomic (relaxed: a count, not a synchronization),
  // so that a thread taking the non-const data<T>() of a leaf shared between
  // threads while another thread's backward() checks that leaf is no data race.
  std::uint64_t version() const { return version_.load(std::memory_order_relaxed); }
  void bump_version() { version_.fetch_add(1, std::memory_order_relaxed); }

 private:
  void* ptr_ = nullptr;
  std::size_t bytes_ = 0;
  std::atomic<std::uint64_t> version_{0};
};

struct StorageStats {
  std::int64_t fresh_allocations = 0;  // buffers obtained from the system allocator
  std::int64_t reused = 0;             // buffers served from the cache
  std::int64_t cached_bytes = 0;       // bytes currently held in the cache
  std::int64_t live_bytes = 0;         // bytes of buffers held by tensors now
  std::int64_t peak_live_bytes = 0;    // largest live_bytes since start or reset_storage_peak()
};

StorageStats storage_stats();
// The most bytes the cache holds: memory_limit() / 4, read when a buffer is given back.
std::size_t storage_cache_limit();
// Returns every cached buffer to the system allocator and, where malloc is
// tuned to keep freed memory (tune_malloc(), autodiff/base/memory.h), asks it to
// return its free memory to the system (malloc_trim).
void release_cached_storage();
// Starts a new peak: peak_live_bytes = live_bytes (benchmarks measure a step's peak).
void reset_storage_peak();

}  // namespace gr
