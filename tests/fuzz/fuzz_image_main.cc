// libFuzzer entry point for the image reader (body in fuzz_targets.cpp).
#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  gr::fuzz::fuzz_image_reader(data, size);
  return 0;
}
