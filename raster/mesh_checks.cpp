// The value checks of raster inputs (see mesh_checks.h).
#include "raster/mesh_checks.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"

namespace gr::raster::detail {

namespace {

// Lowest i in [0, n) with bad(i), or -1. Blocks are fixed by n alone and the
// lowest failing block wins, so the reported element never depends on threads.
// any_bad(lo, hi) is a branch-free (vectorizable) scan of a block; only a
// block that fails it is searched element by element.
template <class AnyBad, class Bad>
std::int64_t first_bad(std::int64_t n, AnyBad any_bad, Bad bad) {
  constexpr std::int64_t kBlock = 65536;
  const std::int64_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<std::int64_t> first(static_cast<std::size_t>(blocks), -1);
  parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b) {
      const std::int64_t hi = std::min(n, (b + 1) * kBlock);
      if (!any_bad(b * kBlock, hi)) continue;
      for (std::int64_t i = b * kBlock; i < hi; ++i)
        if (bad(i)) {
          first[b] = i;
          break;
        }
    }
  });
  for (const std::int64_t f : first)
    if (f >= 0) return f;
  return -1;
}

}  // namespace

void check_image_size(std::int64_t width, std::int64_t height, const char* op) {
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide || width * height > kMaxPixels)
    throw ValueError(std::string(op) + ": image size " + std::to_string(width) + " x " + std::to_string(height) +
                     " is outside 1.." + std::to_string(kMaxSide) + " per side (at most 2^28 pixels)");
}

void check_triangles(const std::int32_t* tris, std::int64_t num_tris, std::int64_t num_vertices,
                     const char* op) {
  if (num_tris < 0 || num_vertices < 0)
    throw ValueError(std::string(op) + ": negative vertex or triangle count");
  if (num_tris > INT32_MAX - 1)
    throw ValueError(std::string(op) + ": too many triangles for int32 tri_id");
  // An index is valid iff, as unsigned, it is below num_vertices (negatives wrap high).
  const std::uint64_t n_ok = static_cast<std::uint64_t>(num_vertices);
  const std::int64_t j = first_bad(
      3 * num_tris,
      [&](std::int64_t lo, std::int64_t hi) {
        std::uint32_t worst = 0;
        for (std::int64_t i = lo; i < hi; ++i) worst = std::max(worst, static_cast<std::uint32_t>(tris[i]));
        return worst >= n_ok;
      },
      [&](std::int64_t i) { return tris[i] < 0 || tris[i] >= num_vertices; });
  if (j >= 0)
    throw IndexError(std::string(op) + ": tris[" + std::to_string(j / 3) + "][" + std::to_string(j % 3) +
                     "] = " + std::to_string(tris[j]) + " is outside [0, " +
                     std::to_string(num_vertices) + ")");
}

void check_tri_ids(const std::int32_t* tri_id, std::int64_t pixels, std::int64_t num_tris,
                   const char* op) {
  const std::uint64_t n_ok = static_cast<std::uint64_t>(num_tris);
  const std::int64_t p = first_bad(
      pixels,
      [&](std::int64_t lo, std::int64_t hi) {
        std::uint32_t worst = 0;
        for (std::int64_t i = lo; i < hi; ++i) worst = std::max(worst, static_cast<std::uint32_t>(tri_id[i]));
        return worst > n_ok;
      },
      [&](std::int64_t i) { return tri_id[i] < 0 || tri_id[i] > num_tris; });
  if (p >= 0)
    throw IndexError(std::string(op) + ": tri_id[" + std::to_string(p) + "] = " +
                     std::to_string(tri_id[p]) + " is outside [0, " + std::to_string(num_tris) + "]");
}

template <class T>
void check_rast_ids(const T* rast, std::int64_t pixels, std::int64_t num_tris, const char* what, const char* op) {
  // A branch-free pass over the ids (vectorized, in parallel) says whether
  // any is bad; only then the pass below finds the first.
  const T top = static_cast<T>(num_tris);
  std::atomic<bool> bad{false};
  parallel_for(0, pixels, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    bool ok = true;
    for (std::int64_t q = lo; q < hi; ++q) {
      const T id = rast[4 * q + 3];
      ok &= (id >= 0) & (id <= top) & (id == std::floor(id));
    }
    if (!ok) bad.store(true, std::memory_order_relaxed);
  });
  if (!bad.load()) return;
  for (std::int64_t q = 0; q < pixels; ++q) {
    const T id = rast[4 * q + 3];
    if (!(id >= 0 && id <= top && id == std::floor(id)))
      throw IndexError(std::string(op) + ": " + what + "[..., 3] (triangle id + 1) at pixel " + std::to_string(q) +
                       " is " + std::to_string(id) + ", not an integer in [0, " + std::to_string(num_tris) +
                       "] (the triangle count of 'tri')");
  }
}

template <class T>
void check_finite(const T* values, std::int64_t count, const char* what, const char* op) {
  // x - x is +0 for every finite x and NaN for Inf or NaN.
  const std::int64_t i = first_bad(
      count,
      [&](std::int64_t lo, std::int64_t hi) {
        unsigned bad = 0;
        for (std::int64_t k = lo; k < hi; ++k) bad |= static_cast<unsigned>(!(values[k] - values[k] == T(0)));
        return bad != 0;
      },
      [&](std::int64_t k) { return !std::isfinite(values[k]); });
  if (i >= 0)
    throw ValueError(std::string(op) + ": " + what + "[" + std::to_string(i) + "] is NaN or Inf");
}

template void check_rast_ids<float>(const float*, std::int64_t, std::int64_t, const char*, const char*);
template void check_rast_ids<double>(const double*, std::int64_t, std::int64_t, const char*, const char*);
template void check_finite<float>(const float*, std::int64_t, const char*, const char*);
template void check_finite<double>(const double*, std::int64_t, const char*, const char*);

}  // namespace gr::raster::detail
