// libFuzzer entry point for shape arithmetic: factories and shape-making ops
// on overflowing extents (body in fuzz_targets.cpp).
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  gr::fuzz::fuzz_shapes(data, size);
  return 0;
}
