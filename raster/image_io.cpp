// Image I/O over stb_image / stb_image_write (implementations live in libstb;
// this file only includes the declarations), and the atomic file writer that
// every gradraster writer goes through.
#include "raster/image_io.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <unistd.h>

#include "autodiff/error.h"

namespace gr::raster {
namespace {

std::string errno_text() { return std::strerror(errno); }

// A file name next to `path` that no other writer (thread or process) uses.
std::string temp_name_for(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
}

// Converts one sample to an 8-bit level: clamp to [0, 1], NaN -> 0, round.
std::uint8_t to_level(double x) {
  if (!(x > 0)) return 0;
  if (x >= 1) return 255;
  return static_cast<std::uint8_t>(x * 255.0 + 0.5);
}

}  // namespace

void write_raw(const std::string& path, const void* data, std::size_t bytes) {
  if (path.empty()) throw IOError("write_raw: empty path");
  const std::string tmp = temp_name_for(path);
  // "x": fail rather than reuse an existing file; permissions follow the umask.
  std::FILE* f = std::fopen(tmp.c_str(), "wbx");
  if (!f) throw IOError("cannot write '" + path + "': " + errno_text());
  bool ok = bytes == 0 || std::fwrite(data, 1, bytes, f) == bytes;
  int saved = errno;
  ok = (std::fflush(f) == 0) && ok;
  if (ok) saved = errno;
  ok = (std::fclose(f) == 0) && ok;
  if (!ok) {
    if (saved == 0) saved = errno;
    std::remove(tmp.c_str());
    throw IOError("cannot write '" + path + "': " + std::strerror(saved));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    saved = errno;
    std::remove(tmp.c_str());
    throw IOError("cannot write '" + path + "': rename failed: " + std::strerror(saved));
  }
}

Tensor read_image(const std::string& path, int channels) {
  if (channels < 0 || channels > 4)
    throw ValueError("read_image('" + path + "'): channels must be 0..4, got " +
                     std::to_string(channels));
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw IOError("cannot read image '" + path + "': " + errno_text());
  int w = 0, h = 0, file_c = 0;
  stbi_set_flip_vertically_on_load_thread(0);  // row 0 stays the top row
  const bool wide = stbi_is_16_bit_from_file(f);  // rewinds the stream
  void* pixels = wide ? static_cast<void*>(stbi_load_from_file_16(f, &w, &h, &file_c, channels))
                      : static_cast<void*>(stbi_load_from_file(f, &w, &h, &file_c, channels));
  std::fclose(f);
  if (!pixels) {
    const char* why = stbi_failure_reason();
    throw IOError("cannot read image '" + path + "': " + (why ? why : "unknown stb_image error"));
  }
  const int c = channels ? channels : file_c;
  Tensor out = Tensor::empty({h, w, c});
  float* dst = out.data<float>();
  const std::size_t n = static_cast<std::size_t>(w) * h * c;
  // Scale the file's levels to [0, 1].
  if (wide) {
    const auto* src = static_cast<const std::uint16_t*>(pixels);
    for (std::size_t i = 0; i < n; ++i) dst[i] = src[i] / 65535.0f;
  } else {
    const auto* src = static_cast<const std::uint8_t*>(pixels);
    for (std::size_t i = 0; i < n; ++i) dst[i] = src[i] / 255.0f;
  }
  stbi_image_free(pixels);
  return out;
}

void write_png(const std::string& path, const Tensor& image) {
  const std::string what = "write_png('" + path + "')";
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
  // Encode in memory, then write atomically.
  std::vector<unsigned char> png;
  auto sink = [](void* ctx, void* data, int size) {
    auto* buf = static_cast<std::vector<unsigned char>*>(ctx);
    const auto* bytes = static_cast<const unsigned char*>(data);
    buf->insert(buf->end(), bytes, bytes + size);
  };
  if (!stbi_write_png_to_func(sink, &png, static_cast<int>(w), static_cast<int>(h),
                              static_cast<int>(c), levels.data(), static_cast<int>(w * c)))
    throw IOError(what + ": PNG encoding failed");
  write_raw(path, png.data(), png.size());
}

}  // namespace gr::raster
