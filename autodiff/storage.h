// Contiguous, 64-byte aligned element buffers shared between tensors.
//
// Buffers are recycled through a size-bucketed cache, so an optimization loop
// that builds the same graph every iteration stops allocating after the first
// iteration. `storage_stats()` counts fresh allocations so tests and benchmarks
// can verify that.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace gr {

class Storage {
 public:
  explicit Storage(std::size_t bytes);  // contents uninitialized
  ~Storage();
  Storage(const Storage&) = delete;
  Storage& operator=(const Storage&) = delete;

  void* data() { return ptr_; }
  const void* data() const { return ptr_; }
  std::size_t bytes() const { return bytes_; }

 private:
  void* ptr_ = nullptr;
  std::size_t bytes_ = 0;
};

struct StorageStats {
  std::int64_t fresh_allocations = 0;  // buffers obtained from the system allocator
  std::int64_t reused = 0;             // buffers served from the cache
  std::int64_t cached_bytes = 0;       // bytes currently held in the cache
  std::int64_t live_bytes = 0;         // bytes of buffers held by tensors now
  std::int64_t peak_live_bytes = 0;    // largest live_bytes since start or reset_storage_peak()
};

StorageStats storage_stats();
// Returns every cached buffer to the system allocator.
void release_cached_storage();
// Starts a new peak: peak_live_bytes = live_bytes (benchmarks measure a step's peak).
void reset_storage_peak();

}  // namespace gr
