// Measures the peak of heap memory taken through operator new (std::vector,
// std::string, std::map, ... in gradraster and in the libraries it calls, such
// as tinyobjloader) while a HeapPeak is alive. The test binary replaces the
// global operator new and delete (heap_peak.cpp) to count live bytes; counting
// is always on and costs two atomic operations per allocation.
//
//   gr::testing::HeapPeak peak;
//   load_obj(...);
//   peak.bytes();  // the most bytes held at once since `peak` was made, above what was held then
//
// Tensor buffers are not taken through operator new: StorageStats counts them.
// ThreadSanitizer's runtime defines operator new itself (a second definition
// does not link), so under TSan nothing is counted: counting() is false and
// bytes() is 0; tests that need a measurement skip it.
#pragma once

#include <cstddef>

namespace gr::testing {

class HeapPeak {
 public:
  HeapPeak();  // starts a new peak (one HeapPeak at a time)
  std::size_t bytes() const;
  // False in builds where operator new cannot be replaced (TSan).
  static bool counting();

 private:
  long long start_;
};

}  // namespace gr::testing
