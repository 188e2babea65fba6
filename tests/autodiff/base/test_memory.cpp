#include <catch2/catch.hpp>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "autodiff/base/memory.h"
#include "ops/ops.h"

using namespace gr;

namespace {

constexpr std::size_t kMiB = std::size_t(1) << 20;

// Sets the memory limit for one test and restores the default afterwards.
struct ScopedMemoryLimit {
  explicit ScopedMemoryLimit(std::size_t bytes) { set_memory_limit(bytes); }
  ~ScopedMemoryLimit() { set_memory_limit(0); }
};

// Where a tensor's buffer starts (the const data<T>(), so no version bump).
const void* address(const Tensor& t) { return t.data<float>(); }

}  // namespace

TEST_CASE("memory: a tensor past the limit is refused with its dtype and shape named", "[autodiff][memory][errors]") {
  ScopedMemoryLimit limit(memory_in_use() + 64 * kMiB);
  const auto fresh = storage_stats().fresh_allocations;
  CHECK_THROWS_AS(Tensor::empty({100000, 100000}), MemoryError);
  CHECK_THROWS_WITH(Tensor::zeros({8192, 8192}, DType::Float64),
                    Catch::Contains("float64[8192, 8192]") && Catch::Contains("512 MiB") &&
                        Catch::Contains("GRADRASTER_MEMORY_LIMIT"));
  CHECK(storage_stats().fresh_allocations == fresh);  // refused before allocating
  Tensor fits = Tensor::zeros({1024, 1024});          // 4 MiB: well within
  CHECK(fits.numel() == 1024 * 1024);
}

TEST_CASE("memory: a MemoryError is a gr::Error, never a bare bad_alloc", "[autodiff][memory][errors]") {
  ScopedMemoryLimit limit(memory_in_use() + kMiB);
  CHECK_THROWS_AS(Tensor::ones({1 << 20}, DType::Float64), Error);
  CHECK_THROWS_AS(Tensor::uniform({1 << 20}, 0, 1, 1, DType::Float64), MemoryError);
}

TEST_CASE("memory: memory_in_use counts live and cached buffers and returns to where it was", "[autodiff][memory]") {
  release_cached_storage();
  const std::size_t before = memory_in_use();
  {
    Tensor a = Tensor::empty({1 << 20});  // 4 MiB
    CHECK(memory_in_use() >= before + 4 * kMiB);
  }
  CHECK(memory_in_use() >= before + 4 * kMiB);  // now in the cache
  release_cached_storage();
  CHECK(memory_in_use() == before);
}

TEST_CASE("memory: cached buffers are released before a request is refused", "[autodiff][memory]") {
  release_cached_storage();
  { Tensor a = Tensor::empty({8 << 20}); }  // 32 MiB, now cached
  REQUIRE(storage_stats().cached_bytes >= std::int64_t(32 * kMiB));
  // Room for a new 24 MiB buffer only once the cached 32 MiB are given back.
  ScopedMemoryLimit limit(memory_in_use() + 8 * kMiB);
  Tensor b = Tensor::empty({6 << 20});
  CHECK(storage_stats().cached_bytes < std::int64_t(32 * kMiB));
}

TEST_CASE("memory: a request past the limit empties the whole cache, large buffers included, before it is served",
          "[autodiff][memory][storage]") {
  release_cached_storage();
  {
    Tensor a = Tensor::empty({12 << 20}), b = Tensor::empty({12 << 20});  // 48 MiB each, then cached
  }
  REQUIRE(storage_stats().cached_bytes >= std::int64_t(96 * kMiB));
  ScopedMemoryLimit limit(memory_in_use() - 96 * kMiB + 64 * kMiB);  // 64 MiB fit only without the cache
  Tensor c = Tensor::empty({16 << 20});
  CHECK(storage_stats().cached_bytes == 0);
}

TEST_CASE("storage: a 48 MiB buffer given back is served again from the cache, not allocated afresh",
          "[autodiff][memory][storage]") {
  release_cached_storage();
  const void* first = nullptr;
  {
    Tensor a = Tensor::empty({12 << 20});  // 48 MiB: above glibc's 32 MiB mmap ceiling
    first = address(a);
  }
  const StorageStats before = storage_stats();
  CHECK(before.cached_bytes >= std::int64_t(48 * kMiB));
  Tensor b = Tensor::empty({12 << 20});
  CHECK(address(b) == first);  // the same pages, already faulted in
  CHECK(storage_stats().reused == before.reused + 1);
  CHECK(storage_stats().fresh_allocations == before.fresh_allocations);
}

TEST_CASE("storage: Tensor::zeros above 64 MiB gives zeros, fresh or recycled after writes, on 1 and 3 threads",
          "[autodiff][memory][storage]") {
  // Above 64 MiB a fresh zeros buffer is mapped in parallel pieces before it is
  // cleared (autodiff/base/storage.cpp, populate); a recycled one is only cleared.
  for (int threads : {1, 3}) {
    set_num_threads(threads);
    release_cached_storage();
    const std::int64_t n = (std::int64_t(96) << 20) / 4 + 3;  // not a whole number of pages
    const void* first = nullptr;
    {
      Tensor a = Tensor::zeros({n});
      const float* d = static_cast<const Tensor&>(a).data<float>();
      CHECK(std::all_of(d, d + n, [](float v) { return v == 0.0f; }));
      float* w = a.data<float>();
      std::fill(w, w + n, 1.5f);  // left dirty for the next request of its size
      first = address(a);
    }
    const Tensor b = Tensor::zeros({n});
    CHECK(address(b) == first);  // the same buffer, from the cache
    const float* d = b.data<float>();
    CHECK(std::all_of(d, d + n, [](float v) { return v == 0.0f; }));
  }
  set_num_threads(0);
}

TEST_CASE("storage: the cache never holds more than a quarter of the memory limit, giving back the oldest buffers first",
          "[autodiff][memory][storage]") {
  release_cached_storage();
  ScopedMemoryLimit limit(memory_in_use() + 400 * kMiB);
  const std::size_t cap = storage_cache_limit();
  CHECK(cap == memory_limit() / 4);
  const std::int64_t buffer = 48 * kMiB;
  REQUIRE(cap >= 2 * std::size_t(buffer));  // room for two 48 MiB buffers, not three
  REQUIRE(cap < 3 * std::size_t(buffer));
  const void* given_back[3];
  {
    Tensor t[3] = {Tensor::empty({12 << 20}), Tensor::empty({12 << 20}), Tensor::empty({12 << 20})};
    for (int i = 0; i < 3; ++i) given_back[i] = address(t[i]);
    for (Tensor& x : t) {
      x = Tensor();  // given back in order 0, 1, 2
      CHECK(storage_stats().cached_bytes <= std::int64_t(cap));
    }
  }
  CHECK(storage_stats().cached_bytes == 2 * buffer);
  // The newest of a size is reused first; buffer 0 went back to the system to make room for 2.
  const std::int64_t fresh = storage_stats().fresh_allocations;
  Tensor x = Tensor::empty({12 << 20}), y = Tensor::empty({12 << 20});
  CHECK(address(x) == given_back[2]);
  CHECK(address(y) == given_back[1]);
  CHECK(storage_stats().fresh_allocations == fresh);
  Tensor z = Tensor::empty({12 << 20});
  CHECK(storage_stats().fresh_allocations == fresh + 1);
  // A buffer larger than the cap is not cached at all.
  const std::size_t in_use = memory_in_use();
  { Tensor big = Tensor::empty({std::int64_t(cap / 4) + 1}); }
  CHECK(storage_stats().cached_bytes == 0);  // nothing else was cached
  CHECK(memory_in_use() == in_use);
}

TEST_CASE("storage: lowering the memory limit shrinks the cache when a buffer is next given back",
          "[autodiff][memory][storage]") {
  release_cached_storage();
  { Tensor a = Tensor::empty({12 << 20}), b = Tensor::empty({12 << 20}); }  // 96 MiB cached
  REQUIRE(storage_stats().cached_bytes >= std::int64_t(96 * kMiB));
  ScopedMemoryLimit limit(memory_in_use() + 100 * kMiB);  // cap: a quarter of it, under 96 MiB
  { Tensor small = Tensor::empty({1024}); }
  CHECK(storage_stats().cached_bytes <= std::int64_t(storage_cache_limit()));
}

TEST_CASE("memory: once malloc is tuned, a 48 MiB block comes from its heap, not a fresh mapping",
          "[autodiff][memory]") {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || __GLIBC_MINOR__ >= 33)
  if (!tune_malloc()) {
    WARN("malloc is not tuned (GRADRASTER_MALLOC_DEFAULTS=1, or a sanitizer's allocator): nothing to check");
    return;
  }
  const std::size_t mapped = mallinfo2().hblkhd;
  void* volatile block = std::malloc(48 * kMiB);  // volatile: the pair must not be optimized away
  REQUIRE(block != nullptr);
  CHECK(mallinfo2().hblkhd == mapped);
  std::free(block);
  CHECK(tune_malloc());  // applied once; later calls give the same answer
#endif
}

TEST_CASE("memory: check_memory_request names the request and the limit", "[autodiff][memory][errors]") {
  ScopedMemoryLimit limit(100 * kMiB);
  CHECK_NOTHROW(check_memory_request(kMiB, "a small render"));
  CHECK_THROWS_AS(check_memory_request(std::size_t(5) << 30, "render 16384x16384"), MemoryError);
  CHECK_THROWS_WITH(check_memory_request(std::size_t(5) << 30, "render 16384x16384"),
                    Catch::Contains("render 16384x16384 needs 5120 MiB") && Catch::Contains("limit is 100 MiB"));
  CHECK_THROWS_AS(check_memory_request(SIZE_MAX, "everything"), MemoryError);
  CHECK(memory_limit() == 100 * kMiB);
}

TEST_CASE("memory: set_memory_limit(0) restores the default", "[autodiff][memory]") {
  const std::size_t def = memory_limit();
  set_memory_limit(kMiB);
  CHECK(memory_limit() == kMiB);
  set_memory_limit(0);
  CHECK(memory_limit() == def);
}

TEST_CASE("memory: sizes parse as bytes or with a K, M, G or T suffix", "[autodiff][memory]") {
  CHECK(parse_memory_size("1048576", "x") == kMiB);
  CHECK(parse_memory_size("512M", "x") == 512 * kMiB);
  CHECK(parse_memory_size("8G", "x") == std::size_t(8) << 30);
  CHECK(parse_memory_size("8GB", "x") == std::size_t(8) << 30);
  CHECK(parse_memory_size("8GiB", "x") == std::size_t(8) << 30);
  CHECK(parse_memory_size("2t", "x") == std::size_t(2) << 40);
  CHECK(parse_memory_size("4k", "x") == 4096);
}

TEST_CASE("memory: malformed sizes are refused with the variable named", "[autodiff][memory][errors]") {
  for (const char* bad : {"", "G", "-1", "0", "1.5G", "8 G", "8X", "8GBB", "8Gi", "8B", "99999999999999999999",
                          "17179869184G", "8G\n"})
    CHECK_THROWS_AS(parse_memory_size(bad, "GRADRASTER_MEMORY_LIMIT"), ValueError);
  CHECK_THROWS_WITH(parse_memory_size("lots", "GRADRASTER_MEMORY_LIMIT"),
                    Catch::Contains("GRADRASTER_MEMORY_LIMIT") && Catch::Contains("'lots'"));
  const std::string huge(100000, '7');  // a long value is quoted by a bounded prefix
  try {
    parse_memory_size(huge + "x", "GRADRASTER_MEMORY_LIMIT");
    FAIL("no error");
  } catch (const ValueError& e) {
    CHECK(std::string(e.what()).size() < 300);
  }
}

TEST_CASE("memory: a direct storage request near SIZE_MAX is refused, not rounded", "[autodiff][memory][errors]") {
  CHECK_THROWS_AS(Storage(SIZE_MAX), MemoryError);
  CHECK_THROWS_AS(Storage(SIZE_MAX / 2 + 1), MemoryError);
}

TEST_CASE("memory: an allocation failure inside an op's kernel becomes a MemoryError naming the op",
          "[autodiff][memory][errors]") {
  // Every op runs its kernels through dispatch_float: a std::bad_alloc (or a
  // std::vector's length_error) from kernel scratch memory leaves it as a gr::Error.
  auto refused = [](auto) -> int { throw std::bad_alloc(); };
  CHECK_THROWS_AS(dispatch_float(DType::Float32, "rasterize", refused), MemoryError);
  CHECK_THROWS_WITH(dispatch_float(DType::Float64, "rasterize", refused),
                    Catch::StartsWith("rasterize: ") && Catch::Contains("refused to allocate"));
  auto too_long = [](auto tag) { return std::vector<decltype(tag)>(SIZE_MAX / 2).size(); };
  CHECK_THROWS_AS(dispatch_float(DType::Float32, "antialias", too_long), MemoryError);
  // Other errors pass through unchanged.
  auto value_error = [](auto) -> int { throw ValueError("texture: tex[3] is NaN or Inf"); };
  CHECK_THROWS_AS(dispatch_float(DType::Float32, "texture", value_error), ValueError);
}

TEST_CASE("memory: GRADRASTER_MEMORY_LIMIT sets the default limit, read again by set_memory_limit(0)",
          "[autodiff][memory]") {
  const char* old = std::getenv("GRADRASTER_MEMORY_LIMIT");
  const std::string saved = old ? old : "";
  setenv("GRADRASTER_MEMORY_LIMIT", "123M", 1);
  set_memory_limit(0);
  CHECK(memory_limit() == 123 * kMiB);
  setenv("GRADRASTER_MEMORY_LIMIT", "12 parsecs", 1);
  CHECK_THROWS_WITH(set_memory_limit(0), Catch::Contains("GRADRASTER_MEMORY_LIMIT") && Catch::Contains("12 parsecs"));
  if (old)
    setenv("GRADRASTER_MEMORY_LIMIT", saved.c_str(), 1);
  else
    unsetenv("GRADRASTER_MEMORY_LIMIT");
  set_memory_limit(0);
  CHECK(memory_limit() != 123 * kMiB);
}

TEST_CASE("memory: threads allocating against a tight limit keep memory_in_use consistent",
          "[autodiff][memory][parallel]") {
  // Each thread holds up to two buffers of 1..4 MiB against a 6 MiB budget, so
  // requests are refused now and then: the count never passes the limit, and
  // once all buffers are gone (cache included) it is back where it started.
  release_cached_storage();
  const std::size_t before = memory_in_use();
  const std::size_t budget = before + 6 * kMiB;
  std::atomic<int> over_limit{0};
  {
    ScopedMemoryLimit limit(budget);
    std::atomic<int> ready{0};
    std::vector<std::thread> pool;
    for (int t = 0; t < 4; ++t)
      pool.emplace_back([&, t] {
        for (ready++; ready.load() < 4;) {
        }
        Tensor held[2];
        for (int i = 0; i < 200; ++i) {
          held[i % 2] = Tensor();
          release_cached_storage();  // every request below is a fresh allocation
          try {
            held[i % 2] = Tensor::empty({std::int64_t((1 + (i + t) % 4) << 18)});
            over_limit += memory_in_use() > budget;
          } catch (const MemoryError&) {
          }
        }
      });
    for (std::thread& t : pool) t.join();
  }
  release_cached_storage();
  CHECK(memory_in_use() == before);
  CHECK(over_limit.load() == 0);
}

TEST_CASE("memory: the storage peak counts buffers held by tensors and not the reuse cache",
          "[autodiff][memory]") {
  const std::int64_t base = storage_stats().live_bytes;
  reset_storage_peak();
  {
    Tensor a = Tensor::empty({4 * 1024 * 1024}, DType::Float32);  // 16 MiB
    CHECK(storage_stats().live_bytes - base >= std::int64_t(16 * kMiB));
  }
  // The buffer went back to the cache: no longer live, but the peak remembers it.
  const StorageStats after = storage_stats();
  CHECK(after.live_bytes == base);
  CHECK(after.peak_live_bytes - base >= std::int64_t(16 * kMiB));
  reset_storage_peak();
  CHECK(storage_stats().peak_live_bytes == base);
}
