#include "raster/io/png_encoder.h"

#include <zlib.h>

#include <algorithm>
#include <cstddef>

#include "autodiff/base/error.h"

namespace gr::raster {
namespace {

constexpr int kFilterUp = 2;  // PNG filter type 2: Filt(x) = Orig(x) - Orig(b)
// A chunk's length is a 31-bit number; the image data is split into chunks of at most this.
constexpr std::size_t kMaxChunkData = std::size_t(1) << 30;

void put_u32(std::vector<unsigned char>& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<unsigned char>(v >> shift));
}

// length, type, data, CRC-32 of type and data (big-endian numbers).
void put_chunk(std::vector<unsigned char>& out, const char type[4], const unsigned char* data, std::size_t size) {
  put_u32(out, static_cast<std::uint32_t>(size));
  const std::size_t type_at = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data, data + size);
  const uLong crc = crc32_z(0L, out.data() + type_at, 4 + size);
  put_u32(out, static_cast<std::uint32_t>(crc));
}

// zlib's deflate stream, ended however the encoder leaves.
class Deflater {
 public:
  explicit Deflater(const std::string& what) : what_(what) {
    const int status = deflateInit(&stream_, Z_BEST_SPEED);
    if (status == Z_MEM_ERROR) throw MemoryError(what + ": zlib could not allocate its state");
    if (status != Z_OK) throw IOError(what + ": zlib's deflateInit failed (" + std::to_string(status) + ")");
  }
  ~Deflater() { deflateEnd(&stream_); }
  Deflater(const Deflater&) = delete;
  Deflater& operator=(const Deflater&) = delete;

  // Compresses `size` bytes (the last call with finish = true) onto `out`.
  void feed(const unsigned char* data, std::size_t size, bool finish, std::vector<unsigned char>& out) {
    stream_.next_in = const_cast<unsigned char*>(data);
    stream_.avail_in = static_cast<uInt>(size);
    const int flush = finish ? Z_FINISH : Z_NO_FLUSH;
    int status = Z_OK;
    do {
      unsigned char buffer[1 << 16];
      stream_.next_out = buffer;
      stream_.avail_out = sizeof buffer;
      status = deflate(&stream_, flush);
      if (status == Z_STREAM_ERROR) throw IOError(what_ + ": zlib's deflate failed");
      out.insert(out.end(), buffer, buffer + (sizeof buffer - stream_.avail_out));
    } while (stream_.avail_out == 0 || (finish && status != Z_STREAM_END));
  }

 private:
  z_stream stream_{};
  const std::string& what_;
};

}  // namespace

std::vector<unsigned char> encode_png_levels(const std::uint8_t* levels, std::int64_t height, std::int64_t width,
                                             int channels, const std::string& what) {
  static const unsigned char kColourType[5] = {0, 0, 4, 2, 6};  // by channel count
  const std::size_t stride = static_cast<std::size_t>(width) * channels;

  // The filtered rows, each led by its filter type byte, deflated one by one.
  std::vector<unsigned char> compressed;
  {
    Deflater deflater(what);
    std::vector<unsigned char> row(1 + stride);
    row[0] = kFilterUp;
    for (std::int64_t y = 0; y < height; ++y) {
      const std::uint8_t* current = levels + y * stride;
      if (y == 0) {
        std::copy(current, current + stride, row.begin() + 1);
      } else {
        const std::uint8_t* above = current - stride;
        for (std::size_t i = 0; i < stride; ++i) row[1 + i] = static_cast<unsigned char>(current[i] - above[i]);
      }
      deflater.feed(row.data(), row.size(), y + 1 == height, compressed);
    }
  }

  std::vector<unsigned char> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<unsigned char> header;
  put_u32(header, static_cast<std::uint32_t>(width));
  put_u32(header, static_cast<std::uint32_t>(height));
  // bit depth 8, colour type, compression 0 (deflate), filter method 0, no interlace
  header.insert(header.end(), {8, kColourType[channels], 0, 0, 0});
  put_chunk(png, "IHDR", header.data(), header.size());
  for (std::size_t at = 0; at < compressed.size(); at += kMaxChunkData)
    put_chunk(png, "IDAT", compressed.data() + at, std::min(kMaxChunkData, compressed.size() - at));
  put_chunk(png, "IEND", nullptr, 0);
  return png;
}

}  // namespace gr::raster
