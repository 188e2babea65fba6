// Items grouped by triangle once, for every adjoint that needs that grouping
// (docs/determinism.md, "Scatter by gathering"). rasterize's adjoint and each
// interpolate adjoint over the same G-buffer read the same tri_id buffer and
// group its pixels the same way (bucket_items keyed by tri_id - 1); so do the
// interpolate adjoints over one fragment list. The first adjoint to run groups
// them here, the others reuse the result. The grouping is the unique ordering
// by (triangle, item), so reusing it changes no bit of any gradient.
#pragma once

#include <cstdint>
#include <mutex>

#include "raster/buckets.h"

namespace gr::raster {

class TriangleGroups {
 public:
  // The items [0, n) grouped by tri_id[i] - 1 over num_tris triangles
  // (tri_id 0 left out), grouped on the first call. Null when this object
  // already holds the grouping of another buffer (the caller groups its items
  // itself): a G-buffer copied and given another tri_id keeps its groups.
  const detail::Buckets* by_triangle(const std::int32_t* tri_id, std::int64_t n, std::int64_t num_tris) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!tri_id_) {
      detail::bucket_items(n, num_tris, [&](std::int64_t i) -> std::int64_t { return tri_id[i] - 1; }, &buckets_);
      tri_id_ = tri_id;
      n_ = n;
      num_tris_ = num_tris;
    }
    return tri_id_ == tri_id && n_ == n && num_tris_ == num_tris ? &buckets_ : nullptr;
  }

 private:
  std::mutex mutex_;
  const std::int32_t* tri_id_ = nullptr;
  std::int64_t n_ = 0, num_tris_ = 0;
  detail::Buckets buckets_;
};

}  // namespace gr::raster
