// Items grouped by triangle once, for every adjoint that needs that grouping
// (docs/determinism.md, "Scatter by gathering"). rasterize's adjoint and each
// interpolate adjoint over the same G-buffer read the same tri_id buffer and
// group its pixels the same way (bucket_items keyed by tri_id - 1); so do the
// interpolate adjoints over one fragment list. The first adjoint to run groups
// them here, the others reuse the result. The grouping is the unique ordering
// by (triangle, item), so reusing it changes no bit of any gradient.
//
// Each object belongs to one tri_id buffer, which it keeps alive: no other
// buffer can take that address while the grouping exists, so a G-buffer whose
// tri_id is replaced (and the old buffer freed, its memory reused) is never
// given the old grouping.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <utility>

#include "raster/buckets.h"

namespace gr::raster {

class TriangleGroups {
 public:
  // The grouping of the buffer at `tri_id`, which `owner` keeps alive.
  TriangleGroups(const std::int32_t* tri_id, std::shared_ptr<const void> owner)
      : tri_id_(tri_id), owner_(std::move(owner)) {}

  // The items [0, n) grouped by tri_id[i] - 1 over num_tris triangles
  // (tri_id 0 left out), grouped on the first call. Null for any other buffer
  // or size (the caller groups its items itself): a G-buffer copied and given
  // another tri_id keeps its groups.
  const detail::Buckets* by_triangle(const std::int32_t* tri_id, std::int64_t n, std::int64_t num_tris) {
    if (tri_id != tri_id_) return nullptr;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!grouped_) {
      detail::bucket_items(n, num_tris, [&](std::int64_t i) -> std::int64_t { return tri_id[i] - 1; }, &buckets_);
      grouped_ = true;
      n_ = n;
      num_tris_ = num_tris;
    }
    return n_ == n && num_tris_ == num_tris ? &buckets_ : nullptr;
  }

 private:
  const std::int32_t* tri_id_;
  std::shared_ptr<const void> owner_;
  std::mutex mutex_;
  bool grouped_ = false;
  std::int64_t n_ = 0, num_tris_ = 0;
  detail::Buckets buckets_;
};

}  // namespace gr::raster
