// The value checks of a raster call's inputs, written once for both front
// ends (ops/check.h for the C++ ops, python/src/common.h for the binding),
// which check types and shapes themselves, then call these on the raw
// arrays. Each scan is parallel and its reported element does not depend on
// the thread count; each throws a gr error (autodiff/base/error.h) naming the op,
// the argument and the bad element.
#pragma once

#include <cstdint>

namespace gr::raster {

// Pixels per side of an image (RasterSettings), and pixels per image.
constexpr std::int64_t kMaxSide = 16384;
constexpr std::int64_t kMaxPixels = std::int64_t(1) << 28;

namespace detail {

// ValueError unless 1 <= width, height <= kMaxSide and width * height <= kMaxPixels.
void check_image_size(std::int64_t width, std::int64_t height, const char* op);
// IndexError naming the triangle, corner and index ("tris[t][k] = v is outside
// [0, N)") if an index is < 0 or >= num_vertices; ValueError for a negative
// count or more triangles than an int32 tri_id numbers.
void check_triangles(const std::int32_t* tris, std::int64_t num_tris, std::int64_t num_vertices, const char* op);
// IndexError naming the pixel if some tri_id (int32, 0 = background) is < 0 or > num_tris.
void check_tri_ids(const std::int32_t* tri_id, std::int64_t pixels, std::int64_t num_tris, const char* op);
// IndexError naming `what` and the pixel if some id of an nvdiffrast G-buffer
// (channel 3 of [pixels, 4], triangle id + 1 as a float) is not an integer in [0, num_tris].
template <class T>
void check_rast_ids(const T* rast, std::int64_t pixels, std::int64_t num_tris, const char* what, const char* op);
// ValueError naming the element ("what[i] is NaN or Inf") if some value is NaN or Inf.
template <class T>
void check_finite(const T* values, std::int64_t count, const char* what, const char* op);

}  // namespace detail
}  // namespace gr::raster
