#include "raster/detail/triangle_groups.h"

#include "autodiff/base/parallel.h"
#include "raster/detail/corner_gather.h"

namespace gr::raster {
namespace {

// Never destroyed: a G-buffer with static storage may give its buckets back
// after this translation unit's statics are gone.
detail::ScratchPool<detail::Buckets>& bucket_pool() {
  static auto* pool = new detail::ScratchPool<detail::Buckets>;
  return *pool;
}

}  // namespace

const detail::Buckets* TriangleGroups::by_triangle(const std::int32_t* tri_id, std::int64_t n,
                                                   std::int64_t num_tris) {
  if (tri_id != tri_id_) return nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!buckets_) {
    detail::ScratchPool<detail::Buckets>::Lease b = bucket_pool().take();
    const detail::Buckets* from = fragments_ ? fragments_->grouped(fragment_count_, num_tris) : nullptr;
    if (from) {
      // Bucket by bucket the fragments' items in the same order, as pixels.
      b->start = from->start;
      b->nonempty = from->nonempty;
      b->item.resize(from->item.size());
      const std::int32_t* frag = from->item.data();
      std::int32_t* pixel = b->item.data();
      parallel_for(0, static_cast<std::int64_t>(from->item.size()), 16384, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t e = lo; e < hi; ++e) pixel[e] = pixel_index_[frag[e]];
      });
    } else {
      detail::bucket_items(n, num_tris, [&](std::int64_t i) -> std::int64_t { return tri_id[i] - 1; }, &*b);
    }
    buckets_.emplace(std::move(b));
    n_ = n;
    num_tris_ = num_tris;
  }
  return n_ == n && num_tris_ == num_tris ? &**buckets_ : nullptr;
}

const detail::Buckets* TriangleGroups::corners_by_vertex(const std::int32_t* tri_id, const std::int32_t* tris,
                                                         std::int64_t num_tris, std::int64_t num_vertices) {
  if (tri_id != tri_id_) return nullptr;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!buckets_ || num_tris_ != num_tris) return nullptr;
  // The grouping reads the rows of the used triangles only: those are compared.
  const std::vector<std::int32_t>& used = (*buckets_)->nonempty;
  auto same_rows = [&] {
    for (std::size_t s = 0; s < used.size(); ++s)
      for (int k = 0; k < 3; ++k)
        if (corner_tris_[3 * s + k] != tris[3 * static_cast<std::int64_t>(used[s]) + k]) return false;
    return true;
  };
  if (!corners_) {  // made once and never changed: a caller may read it while another asks
    detail::ScratchPool<detail::Buckets>::Lease b = bucket_pool().take();
    detail::group_corners(tris, used.data(), static_cast<std::int64_t>(used.size()), nullptr, num_vertices, &*b);
    corners_.emplace(std::move(b));
    corner_tris_.resize(3 * used.size());
    for (std::size_t s = 0; s < used.size(); ++s)
      for (int k = 0; k < 3; ++k) corner_tris_[3 * s + k] = tris[3 * static_cast<std::int64_t>(used[s]) + k];
    corner_vertices_ = num_vertices;
    return &**corners_;
  }
  return corner_vertices_ == num_vertices && same_rows() ? &**corners_ : nullptr;
}

void TriangleGroups::set_fragments(const std::int32_t* tri_id, std::shared_ptr<TriangleGroups> fragments,
                                   const std::int32_t* pixel_index, std::int64_t count,
                                   std::shared_ptr<const void> owner) {
  if (tri_id != tri_id_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  fragments_ = std::move(fragments);
  pixel_index_ = pixel_index;
  fragment_count_ = count;
  pixel_index_owner_ = std::move(owner);
}

const detail::Buckets* TriangleGroups::grouped(std::int64_t n, std::int64_t num_tris) {
  std::lock_guard<std::mutex> lock(mutex_);
  return buckets_ && n_ == n && num_tris_ == num_tris ? &**buckets_ : nullptr;
}

}  // namespace gr::raster
