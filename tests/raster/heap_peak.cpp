// The counting operator new and delete behind HeapPeak (heap_peak.h). Sizes
// come from malloc_usable_size, so every form of delete (sized or not) gives
// back exactly what its new counted.
#include "raster/heap_peak.h"

#include <malloc.h>

#include <atomic>
#include <cstdlib>
#include <new>

#if defined(__SANITIZE_THREAD__)
#define GR_HEAP_PEAK_COUNTS 0
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define GR_HEAP_PEAK_COUNTS 0
#endif
#endif
#ifndef GR_HEAP_PEAK_COUNTS
#define GR_HEAP_PEAK_COUNTS 1
#endif

namespace {

std::atomic<long long> g_live{0};
std::atomic<long long> g_peak{0};

#if GR_HEAP_PEAK_COUNTS
void* counted(std::size_t n) {
  void* p = std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  const long long live = g_live.fetch_add(static_cast<long long>(malloc_usable_size(p))) +
                         static_cast<long long>(malloc_usable_size(p));
  long long peak = g_peak.load(std::memory_order_relaxed);
  while (live > peak && !g_peak.compare_exchange_weak(peak, live)) {
  }
  return p;
}

void uncounted(void* p) noexcept {
  if (!p) return;
  g_live.fetch_sub(static_cast<long long>(malloc_usable_size(p)));
  std::free(p);
}
#endif

}  // namespace

#if GR_HEAP_PEAK_COUNTS
void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  try {
    return counted(n);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept { uncounted(p); }
void operator delete[](void* p) noexcept { uncounted(p); }
void operator delete(void* p, std::size_t) noexcept { uncounted(p); }
void operator delete[](void* p, std::size_t) noexcept { uncounted(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { uncounted(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { uncounted(p); }
#endif

namespace gr::testing {

HeapPeak::HeapPeak() : start_(g_live.load()) { g_peak.store(start_); }

bool HeapPeak::counting() { return GR_HEAP_PEAK_COUNTS != 0; }

std::size_t HeapPeak::bytes() const {
  const long long above = g_peak.load() - start_;
  return above > 0 ? static_cast<std::size_t>(above) : 0;
}

}  // namespace gr::testing
