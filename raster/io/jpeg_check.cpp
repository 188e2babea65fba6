// The JPEG segment walk of jpeg_check.h, from the JPEG standard (ITU T.81,
// B.1.1.2-B.2.4): a marker is 0xFF (fill bytes 0xFF may repeat) and a code;
// SOI, EOI, RSTn and TEM stand alone, every other marker is followed by a
// 16-bit big-endian length that counts itself; after a scan header (SOS),
// entropy-coded data runs up to the next marker that is not 0xFF00 (a stuffed
// byte) or RSTn.
#include "raster/io/jpeg_check.h"

#include <cstdint>

#include "autodiff/base/error.h"

namespace gr::raster {
namespace {

constexpr int kDefineHuffmanTables = 0xC4, kStartOfScan = 0xDA, kEndOfImage = 0xD9;

bool stands_alone(int marker) { return marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8); }

class Bytes {
 public:
  explicit Bytes(std::string_view b) : b_(b) {}
  bool has(std::size_t n) const { return n <= b_.size() - pos_; }
  int u8() { return static_cast<std::uint8_t>(b_[pos_++]); }
  int u8_or_0() { return has(1) ? u8() : 0; }
  void skip(std::size_t n) { pos_ += has(n) ? n : b_.size() - pos_; }
  int u16() {
    const int hi = u8();
    return hi << 8 | u8();
  }
  std::size_t pos() const { return pos_; }
  void seek(std::size_t p) { pos_ = p; }

 private:
  std::string_view b_;
  std::size_t pos_ = 0;
};

// Checks the tables of one DHT segment whose length field leaves `left`
// bytes, read as stb_image reads them: a table is a class/id byte, 16 code
// counts and the codes, and another table is read while the length is not
// used up, also beyond the segment (bytes past the end of the file read as 0).
// Returns false if the tables do not fill the length exactly: stb then stops.
bool check_tables(Bytes& in, long left, const std::string& what) {
  while (left > 0) {
    in.u8_or_0();  // table class and id
    int codes = 0;
    for (int i = 0; i < 16; ++i) codes += in.u8_or_0();
    if (codes > 256)
      throw IOError(what + ": corrupt JPEG: a Huffman table (DHT) defines " + std::to_string(codes) +
                    " codes, at most 256 are possible");
    in.skip(static_cast<std::size_t>(codes));
    left -= 17 + codes;
  }
  return left == 0;
}

// Moves past entropy-coded data to the next marker's 0xFF.
void skip_scan_data(Bytes& in) {
  while (in.has(2)) {
    const std::size_t at = in.pos();
    if (in.u8() != 0xFF) continue;
    const int next = in.u8();
    if (next == 0x00 || (next >= 0xD0 && next <= 0xD7)) continue;
    in.seek(next == 0xFF ? at + 1 : at);
    return;
  }
  in.skip(1);
}

}  // namespace

void check_jpeg_huffman_tables(std::string_view bytes, const std::string& what) {
  Bytes in(bytes);
  if (!in.has(2)) return;
  in.seek(2);  // SOI
  while (in.has(2)) {
    if (in.u8() != 0xFF) continue;  // stray bytes between segments: stb skips them too
    int marker = in.u8();
    while (marker == 0xFF && in.has(1)) marker = in.u8();
    if (marker == kEndOfImage) return;
    if (stands_alone(marker)) continue;
    if (!in.has(2)) return;
    const int length = in.u16();
    if (length < 2) return;  // the decoder reports it
    if (marker == kDefineHuffmanTables) {
      if (!check_tables(in, length - 2, what)) return;
      continue;
    }
    in.skip(static_cast<std::size_t>(length - 2));
    if (marker == kStartOfScan) skip_scan_data(in);
  }
}

}  // namespace gr::raster
