// PNG encoding of 8-bit samples (PNG, ISO/IEC 15948): one IHDR, the image
// data deflated by zlib at its fastest level, IEND. Every row uses the "Up"
// filter (each byte minus the byte above it; the first row as is), which on
// renders compresses about as well as choosing a filter per row and costs one
// subtraction per byte: a 772 x 1546 RGB snapshot strip encodes about 6x
// faster than with stb_image_write, and smaller (docs/decisions.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gr::raster {

// The PNG file of `levels`: height rows of width x channels samples, row 0 the
// top row, channels 1 (grey), 2 (grey + alpha), 3 (RGB) or 4 (RGBA). The
// bytes depend only on the samples (and zlib's version). The caller checks the
// shape (image_io.h's encode_png); `what` starts the error messages (IOError
// if zlib fails, MemoryError if it cannot allocate).
std::vector<unsigned char> encode_png_levels(const std::uint8_t* levels, std::int64_t height, std::int64_t width,
                                             int channels, const std::string& what);

}  // namespace gr::raster
