// Image I/O: reading checks the format (image_format.h) and the size in the
// header before the decoder (image_decoder.h, stb_image built for the accepted
// formats) runs under the memory budget; writing quantizes to 8 bits and
// encodes with raster/io/png_encoder.h. Files go through raster/io/files.h: bytes are read with
// read_input_file, and written through an OutputSet.
#include "raster/io/image_io.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "raster/io/files.h"
#include "raster/io/image_decoder.h"
#include "raster/io/image_format.h"
#include "raster/io/jpeg_check.h"
#include "raster/io/png_encoder.h"

namespace gr::raster {
namespace {

// Converts one sample to an 8-bit level: clamp to [0, 1], NaN -> 0, round.
std::uint8_t to_level(double x) {
  if (!(x > 0)) return 0;
  if (x >= 1) return 255;
  return static_cast<std::uint8_t>(x * 255.0 + 0.5);
}

}  // namespace

void write_raw(const std::string& path, const void* data, std::size_t bytes) {
  OutputSet output;
  output.stage(path, data, bytes);
  output.commit();
}

Tensor read_image(const std::string& path, int channels) {
  if (channels < 0 || channels > 4)
    throw ValueError("read_image('" + path + "'): channels must be 0..4, got " +
                     std::to_string(channels));
  return read_image_from_memory(read_input_file(path, "cannot read image '" + path + "'"), path, channels);
}

Tensor read_image_from_memory(const std::string& file, const std::string& path, int channels) {
  const std::string what = "cannot read image '" + path + "'";
  if (channels < 0 || channels > 4)
    throw ValueError("read_image('" + path + "'): channels must be 0..4, got " +
                     std::to_string(channels));

  // The format from the first bytes, then the size from the header, both
  // checked before anything is decoded.
  if (identify_image_format(file, what) == ImageFormat::Jpeg) check_jpeg_huffman_tables(file, what);
  const ImageHeader header = decode_image_header(file, what);
  check_decodable_size(header, channels, what);
  const int c = channels ? channels : header.channels;
  const std::size_t samples = static_cast<std::size_t>(header.width) * header.height * c;
  const std::size_t tensor_bytes = samples * sizeof(float);
  check_memory_request(samples * (header.sixteen_bit ? 2 : 1) + tensor_bytes,
                       "read_image('" + path + "') " + std::to_string(header.width) + " x " +
                           std::to_string(header.height) + " x " + std::to_string(c));

  // The decoder may hold what the budget leaves once the tensor is counted.
  const std::size_t limit = memory_limit(), used = memory_in_use();
  const std::size_t left = limit > used + tensor_bytes ? limit - used - tensor_bytes : 0;
  const DecodedPixels pixels = decode_image(file, header, channels, left, what);
  Tensor out = Tensor::empty({header.height, header.width, c});
  float* dst = out.data<float>();
  // Scale the file's levels to [0, 1].
  if (header.sixteen_bit) {
    const auto* src = static_cast<const std::uint16_t*>(pixels.samples.get());
    for (std::size_t i = 0; i < samples; ++i) dst[i] = src[i] / 65535.0f;
  } else {
    const auto* src = static_cast<const std::uint8_t*>(pixels.samples.get());
    for (std::size_t i = 0; i < samples; ++i) dst[i] = src[i] / 255.0f;
  }
  return out;
}

std::vector<unsigned char> encode_png(const Tensor& image, const std::string& what) {
  if (!image.defined()) throw ValueError(what + ": image is undefined");
  if (image.dtype() != DType::Float32 && image.dtype() != DType::Float64)
    throw DTypeError(what + ": image must be float32 or float64, got " + image.describe());
  if (image.rank() != 2 && image.rank() != 3)
    throw ShapeError(what + ": image must be H×W×C (C in 1..4) or H×W, got " + image.describe());
  const std::int64_t h = image.size(0), w = image.size(1);
  const std::int64_t c = image.rank() == 3 ? image.size(2) : 1;
  if (c < 1 || c > 4)
    throw ShapeError(what + ": image must have 1 to 4 channels, got " + image.describe());
  if (h < 1 || w < 1 || h > (1 << 24) || w > (1 << 24) ||
      w * c > std::numeric_limits<int>::max() / 2)
    throw ShapeError(what + ": image size out of range, got " + image.describe());

  // Quantize to 8 bits, row 0 first (top row of the PNG).
  std::vector<std::uint8_t> levels(static_cast<std::size_t>(h * w * c));
  if (image.dtype() == DType::Float32) {
    const float* src = image.data<float>();
    for (std::size_t i = 0; i < levels.size(); ++i) levels[i] = to_level(src[i]);
  } else {
    const double* src = image.data<double>();
    for (std::size_t i = 0; i < levels.size(); ++i) levels[i] = to_level(src[i]);
  }
  return encode_png_levels(levels.data(), h, w, static_cast<int>(c), what);
}

void write_png(const std::string& path, const Tensor& image) {
  const std::vector<unsigned char> png = encode_png(image, "write_png('" + path + "')");
  write_raw(path, png.data(), png.size());
}

}  // namespace gr::raster
