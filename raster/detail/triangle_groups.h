// Items grouped by triangle once, for every adjoint that needs that grouping
// (docs/determinism.md, "Scatter by gathering"). rasterize's adjoint and each
// interpolate adjoint over the same G-buffer read the same tri_id buffer and
// group its pixels the same way (bucket_items keyed by tri_id - 1); so do the
// interpolate adjoints over one fragment list. The first adjoint to run groups
// them here, the others reuse the result. The grouping is the unique ordering
// by (triangle, item), so reusing it changes no bit of any gradient.
//
// A G-buffer's pixels can also be grouped from its fragments' grouping: the
// fragments are its covered pixels in ascending order, so mapping each
// fragment to its pixel gives the same buckets in the same order, without a
// pass over every pixel (fragment mode: rasterize's adjoint runs after the
// interpolate adjoints have grouped the fragments).
//
// Each object belongs to one tri_id buffer, which it keeps alive: no other
// buffer can take that address while the grouping exists, so a G-buffer whose
// tri_id is replaced (and the old buffer freed, its memory reused) is never
// given the old grouping.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

#include "raster/detail/buckets.h"
#include "raster/detail/rasterize_setup.h"

namespace gr::raster {

class TriangleGroups {
 public:
  // The grouping of the buffer at `tri_id`, which `owner` keeps alive.
  TriangleGroups(const std::int32_t* tri_id, std::shared_ptr<const void> owner)
      : tri_id_(tri_id), owner_(std::move(owner)) {}
  TriangleGroups(const TriangleGroups&) = delete;
  TriangleGroups& operator=(const TriangleGroups&) = delete;

  // The items [0, n) grouped by tri_id[i] - 1 over num_tris triangles
  // (tri_id 0 left out), grouped on the first call. Null for any other buffer
  // or size (the caller groups its items itself): a G-buffer copied and given
  // another tri_id keeps its groups.
  const detail::Buckets* by_triangle(const std::int32_t* tri_id, std::int64_t n, std::int64_t num_tris);

  // The corners of the triangles by_triangle found (corner j = 3 s + k is
  // corner k of triangle nonempty[s]) grouped by their vertex in tris
  // (group_corners, every corner), grouped at the first call; null where
  // the used triangles' rows of tris or num_vertices differ from that call's
  // (compared by content), and where by_triangle gives null or has not
  // grouped yet. For adjoints whose every covered triangle contributes to its
  // corners (interpolate's): two interpolate adjoints over one G-buffer group
  // the corners once.
  const detail::Buckets* corners_by_vertex(const std::int32_t* tri_id, const std::int32_t* tris, std::int64_t num_tris,
                                           std::int64_t num_vertices);

  // For a G-buffer's groups: `fragments` groups the `count` fragments that
  // list the covered pixels of the buffer at `tri_id` in ascending order,
  // fragment f at pixel pixel_index[f] (kept alive by `owner`). If tri_id is
  // this object's buffer and all those fragments are grouped by the time it
  // is, its grouping is derived from theirs (ignored for any other buffer).
  void set_fragments(const std::int32_t* tri_id, std::shared_ptr<TriangleGroups> fragments,
                     const std::int32_t* pixel_index, std::int64_t count, std::shared_ptr<const void> owner);

 private:
  // The grouping, if made for items [0, n) and num_tris triangles (null otherwise).
  const detail::Buckets* grouped(std::int64_t n, std::int64_t num_tris);

  const std::int32_t* tri_id_;
  std::shared_ptr<const void> owner_;
  std::mutex mutex_;
  std::int64_t n_ = 0, num_tris_ = 0;
  // The grouping once made, in buffers leased from a pool and given back with
  // this object (a new G-buffer every iteration must not page-fault new ones in).
  std::optional<detail::ScratchPool<detail::Buckets>::Lease> buckets_;
  // corners_by_vertex's grouping and the triangles and vertex count it is of.
  std::optional<detail::ScratchPool<detail::Buckets>::Lease> corners_;
  std::vector<std::int32_t> corner_tris_;  // the used triangles' rows, in nonempty order
  std::int64_t corner_vertices_ = -1;
  // set_fragments' arguments.
  std::shared_ptr<TriangleGroups> fragments_;
  const std::int32_t* pixel_index_ = nullptr;
  std::int64_t fragment_count_ = 0;
  std::shared_ptr<const void> pixel_index_owner_;
};

}  // namespace gr::raster
