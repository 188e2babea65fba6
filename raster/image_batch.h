// The minibatch of a batched raster call, shared by the C++ ops (ops/render/batch.h)
// and the Python binding (python/src/common.h), as nvdiffrast draws it:
// instanced mode (positions per image, every image all M triangles) or range
// mode (one position list, image b the triangles first .. first + count - 1).
// Images run in parallel (each kernel is parallel inside, so small images
// keep every core busy); a gradient the images share is summed in image order.
#pragma once

#include <cstdint>
#include <vector>

#include "autodiff/base/parallel.h"

namespace gr::raster {

struct ImageBatch {
  struct Range {
    std::int64_t first, count;
  };
  bool instanced = false;
  std::int64_t images = 0;     // B
  std::int64_t vertices = 0;   // N, rows of each image's positions
  std::int64_t triangles = 0;  // M, the whole triangle list
  std::vector<Range> ranges;   // range mode: one per image; instanced: empty

  // Instanced: `images` position sets of N rows, each drawing all M triangles.
  static ImageBatch instanced_mode(std::int64_t images, std::int64_t vertices, std::int64_t triangles);
  // Range mode: one position set, image b drawing ranges[b]. IndexError naming
  // the image ("ranges[b] = (first, count) is outside the M triangles of
  // '<tri_name>'") unless 0 <= first, 0 <= count and first + count <= M.
  static ImageBatch range_mode(std::vector<Range> ranges, std::int64_t vertices, std::int64_t triangles,
                               const char* op, const char* tri_name);

  // Offset of image b's positions, in values (4 per vertex; 0 in range mode).
  std::int64_t pos_offset(std::int64_t b) const { return instanced ? 4 * vertices * b : 0; }
  // Image b's triangles: all of them (instanced) or its range.
  Range range(std::int64_t b) const { return instanced ? Range{0, triangles} : ranges[static_cast<std::size_t>(b)]; }
};

// Runs body(b) for every image b in [0, images): images in parallel through
// autodiff/base/parallel.h, kernels parallel inside.
template <class F>
void for_each_image(std::int64_t images, F&& body) {
  parallel_for(0, images, 1, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t b = lo; b < hi; ++b) body(b);
  });
}

// The one batched sum of per-image gradient parts: total[i] += parts[0][i],
// then += parts[1][i], ... (images in order, each element one fixed sequence
// of additions), so a gradient the images share is the sum separate calls
// would accumulate, bit-identical for any thread count. n values per part.
template <class T>
void sum_in_image_order(const T* const* parts, std::int64_t count, std::int64_t n, T* total);

}  // namespace gr::raster
