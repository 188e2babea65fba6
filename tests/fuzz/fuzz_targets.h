// Fuzz bodies, shared by the libFuzzer entry points (fuzz_*_main.cc, built with
// -DGRADRASTER_FUZZ=ON, see fuzz.cmake) and the corpus replay test
// (test_fuzz_corpus.cpp), so every seed is also a regression test.
//
// Contract checked by every body: the code under test either throws a gr::Error
// (autodiff/base/error.h), which the body swallows, or returns finite outputs and
// gradients (for the raster body: the G-buffer always; interpolated values,
// screen derivatives and gradients when every clip and attribute value has
// magnitude <= 1e4, since inputs near the float range may overflow them
// legitimately). Anything else (a non-finite value, a foreign exception) escapes as
// FuzzContractViolation; libFuzzer reports it as a crash, Catch2 as a failure.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace gr::fuzz {

struct FuzzContractViolation : std::logic_error {
  using std::logic_error::logic_error;
};

// The bytes are OBJ text for raster::load_obj_from_string. Its error messages
// must also be short (at most 512 bytes) and free of control bytes.
void fuzz_obj_loader(const std::uint8_t* data, std::size_t size);

// The bytes are an image file for raster::read_image_from_memory, under a
// 64 MiB memory limit (so a header that claims a huge size, or data that
// expands far beyond it, is refused quickly). Contract: a gr::Error, or an
// H x W x C float32 image (C in 1..4) whose every value lies in [0, 1].
void fuzz_image_reader(const std::uint8_t* data, std::size_t size);

// The bytes encode a small scene (see RasterCase) that goes through
// rasterize -> interpolate (or interpolate_with_derivatives) -> backward.
// No known issue is tolerated: the two this fuzzer found (a NaN/Inf interpolate
// background, an Inf float32 clip gradient for |w| -> 0) are fixed and their
// reproducers are seeds in corpus/raster.
void fuzz_rasterize_interpolate(const std::uint8_t* data, std::size_t size);

// The bytes encode two shapes and an op (see fuzz_targets.cpp, decode_shape):
// a tensor of the first shape is made and combined with the second by reshape,
// broadcast_to, concat, stack, matmul, sum or slice, under a 16 MiB memory
// limit. Extents range over small values, 2^31, 2^32, 2^62, INT64_MAX and
// negative ones, so element and byte counts overflow. Contract: a gr::Error
// (ShapeError, MemoryError, ...), or a result whose element count is the
// product of its extents and whose every element can be written and read.
void fuzz_shapes(const std::uint8_t* data, std::size_t size);

// A raster fuzz input in readable form, for writing seeds. Byte layout:
//   flags (bit 0 float64, bits 1-2 cull None/Back/Front, bit 3 linear
//   interpolation, bit 4 with derivatives, bit 5 background value), width-1
//   (mod 16), height-1 (mod 16), vertex count (mod 16), triangle count
//   (mod 16), channels-1 (mod 4); then 4 values per vertex (clip), 3 indices per
//   triangle, channels values per vertex (attributes), channels background
//   values, and upstream weights (defaulting to 1) for the output, depth and uv.
// A value is one tag byte: < 0xE0 means (tag - 112) / 32; 0xE0..0xEF are
// specials (0, -0, NaN, +-Inf, +-1e38, +-1e-40, FLT_MAX, 1e-30, 1e30, 1e300,
// 1e-310, +-1e6); 0xF0..0xFE are the integers -7..7; 0xFF is followed by the raw
// bits of a float (4 bytes) or double (8 bytes, float64 cases). An index is one
// byte: < 0xF8 means byte % vertex count; 0xF8..0xFB are -1, N, INT32_MIN,
// INT32_MAX; 0xFC..0xFF are followed by 4 raw little-endian bytes. Missing
// bytes read as 0.
struct RasterCase {
  bool float64 = false;
  int cull = 0;  // 0 None, 1 Back, 2 Front
  bool linear = false;
  bool with_derivatives = false;
  bool background = false;
  int width = 8, height = 8, channels = 1;
  std::vector<double> clip;                // 4 per vertex
  std::vector<std::int32_t> triangles;     // 3 per triangle
  std::vector<double> attributes;          // channels per vertex
  std::vector<double> background_values;   // channels
};

// Encodes `c` in the byte layout above (every value and index as raw bits).
std::vector<std::uint8_t> encode_raster_case(const RasterCase& c);

}  // namespace gr::fuzz
