// The batch layer both front ends share (raster/image_batch.h): the two modes'
// image geometry, the range check naming the image, every image visited once,
// and the image-order sum, bit-identical for 1, 2 and 8 threads and equal to
// adding the parts one after the other.
#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/image_batch.h"

using namespace gr;
using raster::ImageBatch;

TEST_CASE("image batch: instanced images own their positions and draw every triangle", "[raster][image_batch]") {
  const ImageBatch b = ImageBatch::instanced_mode(3, 10, 7);
  CHECK(b.instanced);
  CHECK(b.images == 3);
  for (std::int64_t i = 0; i < 3; ++i) {
    CHECK(b.pos_offset(i) == 40 * i);
    CHECK(b.range(i).first == 0);
    CHECK(b.range(i).count == 7);
  }
}

TEST_CASE("image batch: range-mode images share the positions and draw their range", "[raster][image_batch]") {
  const ImageBatch b = ImageBatch::range_mode({{0, 7}, {2, 3}, {7, 0}}, 10, 7, "op", "tri");
  CHECK_FALSE(b.instanced);
  CHECK(b.images == 3);
  CHECK(b.pos_offset(2) == 0);
  CHECK(b.range(1).first == 2);
  CHECK(b.range(1).count == 3);
  CHECK(b.range(2).first == 7);  // an empty range at the end is valid
  CHECK(b.range(2).count == 0);
}

TEST_CASE("image batch: a range outside [0, M] is an IndexError naming the image, the range and the argument",
          "[raster][image_batch][errors]") {
  auto check = [](std::vector<ImageBatch::Range> r, const std::string& expected) {
    try {
      ImageBatch::range_mode(r, 10, 7, "myop", "tri");
      FAIL("no exception");
    } catch (const IndexError& e) {
      CHECK(std::string(e.what()) == expected);
    }
  };
  check({{0, 7}, {5, 3}}, "myop: ranges[1] = (5, 3) is outside the 7 triangles of 'tri'");
  check({{-1, 2}}, "myop: ranges[0] = (-1, 2) is outside the 7 triangles of 'tri'");
  check({{0, 1}, {0, 1}, {2, -1}}, "myop: ranges[2] = (2, -1) is outside the 7 triangles of 'tri'");
  check({{8, 0}}, "myop: ranges[0] = (8, 0) is outside the 7 triangles of 'tri'");
  // first + count would overflow int64 if the check added them.
  check({{1, INT64_MAX}}, "myop: ranges[0] = (1, " + std::to_string(INT64_MAX) + ") is outside the 7 triangles of 'tri'");
}

TEST_CASE("image batch: for_each_image visits every image exactly once", "[raster][image_batch][parallel]") {
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    std::vector<std::atomic<int>> seen(37);
    raster::for_each_image(37, [&](std::int64_t b) { seen[static_cast<std::size_t>(b)]++; });
    for (const auto& s : seen) CHECK(s == 1);
  }
  set_num_threads(0);
}

namespace {

// parts, then total += parts in image order with `threads` threads.
template <class T>
std::vector<T> image_order_sum(int threads, const std::vector<std::vector<T>>& parts, std::vector<T> total) {
  set_num_threads(threads);
  std::vector<const T*> from;
  for (const auto& p : parts) from.push_back(p.data());
  raster::sum_in_image_order(from.data(), static_cast<std::int64_t>(from.size()),
                             static_cast<std::int64_t>(total.size()), total.data());
  set_num_threads(0);
  return total;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

}  // namespace

TEMPLATE_TEST_CASE("image batch: the image-order sum is bit-identical for 1, 2 and 8 threads and equals adding the "
                   "parts one after the other",
                   "[raster][image_batch][determinism]", float, double) {
  // Over several blocks of kElementwiseGrain, values of mixed magnitude so
  // that another summation order would round differently.
  const std::size_t n = 3 * static_cast<std::size_t>(kElementwiseGrain) + 17;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> mag(-8, 8), sign(-1, 1);
  std::vector<std::vector<TestType>> parts(9, std::vector<TestType>(n));
  for (auto& p : parts)
    for (TestType& x : p) x = static_cast<TestType>(sign(rng) * std::pow(10.0, mag(rng)));
  std::vector<TestType> start(n);
  for (TestType& x : start) x = static_cast<TestType>(sign(rng));

  std::vector<TestType> serial = start;  // the definition: one image after the other
  for (const auto& p : parts)
    for (std::size_t i = 0; i < n; ++i) serial[i] += p[i];
  const std::vector<TestType> one = image_order_sum(1, parts, start);
  CHECK(same_bits(one, serial));
  CHECK(same_bits(image_order_sum(2, parts, start), one));
  CHECK(same_bits(image_order_sum(8, parts, start), one));
  // The order matters: the reversed order rounds differently somewhere.
  std::vector<std::vector<TestType>> reversed(parts.rbegin(), parts.rend());
  CHECK_FALSE(same_bits(image_order_sum(1, reversed, start), one));
}
