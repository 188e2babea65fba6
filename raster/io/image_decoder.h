// The pixel decoder behind read_image: stb_image compiled for PNG, JPEG, BMP
// and TGA only (the other formats are not even built), with every allocation
// it makes counted against a limit, so no decode can outgrow the memory budget
// (a PNG whose compressed data expands far beyond the size in its header, a
// "decompression bomb", is stopped at the limit).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

namespace gr::raster {

// What an image's header says.
struct ImageHeader {
  int width = 0, height = 0;
  int channels = 0;           // in the file: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA
  bool sixteen_bit = false;   // 16 bits per sample (PNG only)
};

// Reads the header of a PNG, JPEG, BMP or TGA file held in `bytes`; throws
// IOError starting with `what` (and the decoder's reason) if it cannot, or
// naming the size if it is too large to decode (check_decodable_size).
ImageHeader decode_image_header(std::string_view bytes, const std::string& what);

// The sizes the decoder handles: sides in 1..kMaxImageSide and at most
// kMaxDecodedImageBytes of samples (raster/io/image_io.h) in the file's channels
// or in `channels` (if more). Throws IOError starting with `what` that names
// the size otherwise.
void check_decodable_size(const ImageHeader& header, int channels, const std::string& what);

// Decoded samples: height rows of width pixels of `channels` samples, row 0 at
// the top, 1 byte per sample (or 2, native endian, for sixteen_bit headers).
struct DecodedPixels {
  struct Free {
    void operator()(void* p) const;
  };
  std::unique_ptr<void, Free> samples;
  int width = 0, height = 0, channels = 0;
};

// Decodes `bytes` to `channels` samples per pixel (0 keeps the file's). The
// decoder's own allocations may hold at most `allocation_limit` bytes at any
// moment. Throws MemoryError starting with `what` if the decode needed more,
// IOError (with the decoder's reason) for truncated or corrupt data.
DecodedPixels decode_image(std::string_view bytes, const ImageHeader& header, int channels,
                           std::size_t allocation_limit, const std::string& what);

}  // namespace gr::raster
