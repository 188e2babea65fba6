// Image I/O over stb_image / stb_image_write (implementations live in libstb;
// this file only includes the declarations). Files go through raster/files.h:
// bytes are read with read_input_file, and written through an OutputSet.
#include "raster/image_io.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "autodiff/error.h"
#include "autodiff/memory.h"
#include "raster/files.h"

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
  const std::string what = "cannot read image '" + path + "'";
  if (channels < 0 || channels > 4)
    throw ValueError("read_image('" + path + "'): channels must be 0..4, got " +
                     std::to_string(channels));
  const std::string file = read_input_file(path, what);
  const auto* bytes = reinterpret_cast<const stbi_uc*>(file.data());
  if (file.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw IOError(what + ": file too large for the image decoder");
  const int size = static_cast<int>(file.size());

  // Size from the header, checked before anything is decoded.
  int w = 0, h = 0, file_c = 0;
  if (!stbi_info_from_memory(bytes, size, &w, &h, &file_c)) {
    const char* why = stbi_failure_reason();
    throw IOError(what + ": " + (why && *why ? why : "not a PNG, JPEG, BMP or TGA image"));
  }
  if (w < 1 || h < 1 || w > kMaxImageSide || h > kMaxImageSide)
    throw IOError(what + ": the header says " + std::to_string(w) + " x " + std::to_string(h) +
                  " pixels; each side must lie in 1.." + std::to_string(kMaxImageSide));
  const bool wide = stbi_is_16_bit_from_memory(bytes, size);
  const int c = channels ? channels : file_c;
  // The decoded samples (1 or 2 bytes each) and the float32 tensor.
  const std::size_t samples = static_cast<std::size_t>(w) * h * c;
  check_memory_request(samples * (wide ? 2 : 1) + samples * sizeof(float),
                       "read_image('" + path + "') " + std::to_string(w) + " x " + std::to_string(h) +
                           " x " + std::to_string(c));

  stbi_set_flip_vertically_on_load_thread(0);  // row 0 stays the top row
  void* pixels = wide ? static_cast<void*>(stbi_load_16_from_memory(bytes, size, &w, &h, &file_c, channels))
                      : static_cast<void*>(stbi_load_from_memory(bytes, size, &w, &h, &file_c, channels));
  if (!pixels) {
    // stb's reasons are terse and sometimes empty or a chunk-name fragment.
    const char* why = stbi_failure_reason();
    throw IOError(what + ": truncated or corrupt image data (decoder: " + (why && *why ? why : "no reason given") +
                  ")");
  }
  Tensor out;
  try {
    out = Tensor::empty({h, w, c});
  } catch (...) {
    stbi_image_free(pixels);
    throw;
  }
  float* dst = out.data<float>();
  // Scale the file's levels to [0, 1].
  if (wide) {
    const auto* src = static_cast<const std::uint16_t*>(pixels);
    for (std::size_t i = 0; i < samples; ++i) dst[i] = src[i] / 65535.0f;
  } else {
    const auto* src = static_cast<const std::uint8_t*>(pixels);
    for (std::size_t i = 0; i < samples; ++i) dst[i] = src[i] / 255.0f;
  }
  stbi_image_free(pixels);
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
  std::vector<unsigned char> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* buf = static_cast<std::vector<unsigned char>*>(ctx);
    const auto* bytes = static_cast<const unsigned char*>(data);
    buf->insert(buf->end(), bytes, bytes + size);
  };
  if (!stbi_write_png_to_func(sink, &png, static_cast<int>(w), static_cast<int>(h),
                              static_cast<int>(c), levels.data(), static_cast<int>(w * c)))
    throw IOError(what + ": PNG encoding failed");
  return png;
}

void write_png(const std::string& path, const Tensor& image) {
  const std::vector<unsigned char> png = encode_png(image, "write_png('" + path + "')");
  write_raw(path, png.data(), png.size());
}

}  // namespace gr::raster
