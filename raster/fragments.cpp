// Fragment compaction and row moves. Every loop writes disjoint outputs and
// sums run over fixed blocks in order: results never depend on thread count.
#include "raster/fragments.h"

#include <algorithm>

#include "autodiff/base/parallel.h"

namespace gr::raster {

FragmentPlan plan_fragments(const std::int32_t* tri_id, std::int64_t pixels) {
  FragmentPlan plan;
  const std::int64_t blocks = (pixels + FragmentPlan::kBlock - 1) / FragmentPlan::kBlock;
  plan.block_start.assign(static_cast<std::size_t>(blocks + 1), 0);
  parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b) {
      const std::int64_t lo = b * FragmentPlan::kBlock, hi = std::min(pixels, lo + FragmentPlan::kBlock);
      std::int64_t n = 0;
      for (std::int64_t p = lo; p < hi; ++p) n += tri_id[p] != 0;
      plan.block_start[static_cast<std::size_t>(b + 1)] = n;
    }
  });
  // Exclusive prefix sum: block_start[b] = covered pixels before block b.
  for (std::int64_t b = 0; b < blocks; ++b) plan.block_start[b + 1] += plan.block_start[b];
  return plan;
}

void compact_fragments(const std::int32_t* tri_id, std::int64_t pixels, const FragmentPlan& plan,
                       std::int32_t* pixel_index, std::int32_t* frag_tri_id) {
  const std::int64_t blocks = static_cast<std::int64_t>(plan.block_start.size()) - 1;
  parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b) {
      const std::int64_t lo = b * FragmentPlan::kBlock, hi = std::min(pixels, lo + FragmentPlan::kBlock);
      std::int64_t f = plan.block_start[static_cast<std::size_t>(b)];
      for (std::int64_t p = lo; p < hi; ++p) {
        if (tri_id[p] == 0) continue;
        pixel_index[f] = static_cast<std::int32_t>(p);
        frag_tri_id[f] = tri_id[p];
        ++f;
      }
    }
  });
}

namespace {
// Rows per parallel chunk when each row moves `channels` values.
std::int64_t row_grain(std::int64_t channels) {
  return std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, channels));
}
}  // namespace

template <class T>
void gather_fragment_rows(const T* image, const std::int32_t* pixel_index, std::int64_t count,
                          std::int64_t C, T* rows) {
  parallel_for(0, count, row_grain(C), [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t f = lo; f < hi; ++f) {
      const T* src = image + static_cast<std::int64_t>(pixel_index[f]) * C;
      std::copy(src, src + C, rows + f * C);
    }
  });
}

template <class T>
void scatter_fragment_rows(const T* rows, const std::int32_t* pixel_index, std::int64_t count,
                           std::int64_t C, T* image) {
  parallel_for(0, count, row_grain(C), [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t f = lo; f < hi; ++f)
      std::copy(rows + f * C, rows + (f + 1) * C, image + static_cast<std::int64_t>(pixel_index[f]) * C);
  });
}

template <class T>
void fill_pixels(const T* value, std::int64_t pixels, std::int64_t C, T* image) {
  parallel_for(0, pixels, row_grain(C), [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t p = lo; p < hi; ++p) std::copy(value, value + C, image + p * C);
  });
}

template <class T>
void sum_uncovered(const T* image, std::int64_t pixels, std::int64_t C, const std::int32_t* pixel_index,
                   std::int64_t count, T* sum) {
  constexpr std::int64_t kBlock = 16384;
  const std::int64_t blocks = (pixels + kBlock - 1) / kBlock;
  std::vector<double> partial(static_cast<std::size_t>(blocks * C), 0.0);
  parallel_for(0, blocks, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b) {
      const std::int64_t lo = b * kBlock, hi = std::min(pixels, lo + kBlock);
      // The first fragment at or after pixel lo; fragments are ascending.
      std::int64_t f = std::lower_bound(pixel_index, pixel_index + count, lo) - pixel_index;
      double* acc = partial.data() + b * C;
      for (std::int64_t p = lo; p < hi; ++p) {
        if (f < count && pixel_index[f] == p) {
          ++f;
          continue;
        }
        for (std::int64_t c = 0; c < C; ++c) acc[c] += image[p * C + c];
      }
    }
  });
  for (std::int64_t c = 0; c < C; ++c) {
    double s = 0.0;
    for (std::int64_t b = 0; b < blocks; ++b) s += partial[static_cast<std::size_t>(b * C + c)];
    sum[c] = static_cast<T>(s);
  }
}

template <class T>
void zero_fragment_rows(const std::int32_t* pixel_index, std::int64_t count, std::int64_t C, T* image) {
  parallel_for(0, count, row_grain(C), [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t f = lo; f < hi; ++f) {
      T* dst = image + static_cast<std::int64_t>(pixel_index[f]) * C;
      std::fill(dst, dst + C, T(0));
    }
  });
}

#define GR_INSTANTIATE(T)                                                                                     \
  template void gather_fragment_rows<T>(const T*, const std::int32_t*, std::int64_t, std::int64_t, T*);       \
  template void scatter_fragment_rows<T>(const T*, const std::int32_t*, std::int64_t, std::int64_t, T*);      \
  template void fill_pixels<T>(const T*, std::int64_t, std::int64_t, T*);                                     \
  template void sum_uncovered<T>(const T*, std::int64_t, std::int64_t, const std::int32_t*, std::int64_t, T*); \
  template void zero_fragment_rows<T>(const std::int32_t*, std::int64_t, std::int64_t, T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
GR_INSTANTIATE(std::int32_t)
#undef GR_INSTANTIATE

}  // namespace gr::raster
