// ImageBatch's range check and the image-order sum (see image_batch.h).
#include "raster/image_batch.h"

#include <string>
#include <utility>

#include "autodiff/base/error.h"

namespace gr::raster {

ImageBatch ImageBatch::instanced_mode(std::int64_t images, std::int64_t vertices, std::int64_t triangles) {
  ImageBatch batch;
  batch.instanced = true;
  batch.images = images;
  batch.vertices = vertices;
  batch.triangles = triangles;
  return batch;
}

ImageBatch ImageBatch::range_mode(std::vector<Range> ranges, std::int64_t vertices, std::int64_t triangles,
                                  const char* op, const char* tri_name) {
  const std::int64_t M = triangles;
  for (std::size_t b = 0; b < ranges.size(); ++b) {
    const auto [first, count] = ranges[b];
    if (first < 0 || count < 0 || first > M || count > M - first)
      throw IndexError(std::string(op) + ": ranges[" + std::to_string(b) + "] = (" + std::to_string(first) + ", " +
                       std::to_string(count) + ") is outside the " + std::to_string(M) + " triangles of '" +
                       tri_name + "'");
  }
  ImageBatch batch;
  batch.images = static_cast<std::int64_t>(ranges.size());
  batch.vertices = vertices;
  batch.triangles = triangles;
  batch.ranges = std::move(ranges);
  return batch;
}

template <class T>
void sum_in_image_order(const T* const* parts, std::int64_t count, std::int64_t n, T* total) {
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t b = 0; b < count; ++b)
      for (std::int64_t i = lo; i < hi; ++i) total[i] += parts[b][i];
  });
}
template void sum_in_image_order<float>(const float* const*, std::int64_t, std::int64_t, float*);
template void sum_in_image_order<double>(const double* const*, std::int64_t, std::int64_t, double*);

}  // namespace gr::raster
