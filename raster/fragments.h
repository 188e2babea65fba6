// Fragment lists (no tape): the covered pixels of a G-buffer, compacted in
// ascending pixel order, and the row moves between an image and a fragment
// list. Used by ops/render/fragments.h so shading work follows coverage instead of
// width x height.
#pragma once

#include <cstdint>
#include <vector>

namespace gr::raster {

// Fixed pixel blocks and the number of covered pixels before each, so the
// compaction can fill in parallel and still list pixels in ascending order.
struct FragmentPlan {
  static constexpr std::int64_t kBlock = 16384;  // pixels per block (fixed: result independent of threads)
  std::vector<std::int64_t> block_start;          // blocks + 1 entries; back() = fragment count
  std::int64_t count() const { return block_start.empty() ? 0 : block_start.back(); }
};

// Counts the pixels with tri_id != 0 per block (in parallel), then prefix-sums.
FragmentPlan plan_fragments(const std::int32_t* tri_id, std::int64_t pixels);

// pixel_index[f], frag_tri_id[f] (plan.count() each) = the f-th covered pixel
// in row-major order and its tri_id.
void compact_fragments(const std::int32_t* tri_id, std::int64_t pixels, const FragmentPlan& plan,
                       std::int32_t* pixel_index, std::int32_t* frag_tri_id);

// rows[f, :] = image[pixel_index[f], :] (count rows of `channels` values).
template <class T>
void gather_fragment_rows(const T* image, const std::int32_t* pixel_index, std::int64_t count,
                          std::int64_t channels, T* rows);

// image[pixel_index[f], :] = rows[f, :]; other pixels are left as they are
// (pixel indices are distinct, so the writes are disjoint).
template <class T>
void scatter_fragment_rows(const T* rows, const std::int32_t* pixel_index, std::int64_t count,
                           std::int64_t channels, T* image);

// Every pixel of `image` (pixels x channels) set to `value` (channels values).
template <class T>
void fill_pixels(const T* value, std::int64_t pixels, std::int64_t channels, T* image);

// sum[c] = sum of image[p, c] over the pixels p NOT in pixel_index (ascending),
// accumulated in double over fixed pixel blocks added in order, so the result
// is bit-identical for any thread count.
template <class T>
void sum_uncovered(const T* image, std::int64_t pixels, std::int64_t channels, const std::int32_t* pixel_index,
                   std::int64_t count, T* sum);

// image[pixel_index[f], :] = 0 for every fragment.
template <class T>
void zero_fragment_rows(const std::int32_t* pixel_index, std::int64_t count, std::int64_t channels, T* image);

}  // namespace gr::raster
