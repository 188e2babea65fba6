// Image files built byte by byte for the image reader's tests: PNG chunks
// (with their CRCs), a PNG whose compressed data expands far beyond its
// header, and the formats stb_image_write encodes (PNG, BMP, TGA, JPEG,
// Radiance HDR) from a small test pattern.
#pragma once

#include <stb/stb_image_write.h>

#include <cstdint>
#include <string>
#include <vector>

namespace gr::testing {

inline std::uint32_t crc32(const std::string& bytes) {
  std::uint32_t c = 0xffffffffu;
  for (unsigned char b : bytes) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

inline void put_be32(std::string& s, std::uint32_t x) {
  for (int k = 3; k >= 0; --k) s += static_cast<char>((x >> (8 * k)) & 0xff);
}

inline void put_chunk(std::string& png, const std::string& type, const std::string& data) {
  put_be32(png, static_cast<std::uint32_t>(data.size()));
  png += type + data;
  put_be32(png, crc32(type + data));
}

// A PNG: signature, IHDR (8-bit unless `depth` says otherwise), one IDAT
// holding `zlib`, IEND. Colour type 0 grey, 2 RGB, 6 RGBA.
inline std::string png_file(std::uint32_t width, std::uint32_t height, int colour_type, const std::string& zlib,
                            int depth = 8) {
  std::string ihdr;
  put_be32(ihdr, width);
  put_be32(ihdr, height);
  ihdr += {static_cast<char>(depth), static_cast<char>(colour_type), 0, 0, 0};
  std::string png = "\x89PNG\r\n\x1a\n";
  put_chunk(png, "IHDR", ihdr);
  put_chunk(png, "IDAT", zlib);
  put_chunk(png, "IEND", "");
  return png;
}

// A zlib stream that inflates to `zeros` zero bytes in about zeros / 160
// bytes: one fixed-Huffman block of a literal 0 and copies of 258 bytes at
// distance 1 (13 bits each), then the end of block.
inline std::string zlib_of_zeros(std::size_t zeros) {
  std::string out = "\x78\x01";
  std::uint32_t acc = 0;
  int bits = 0;
  auto put = [&](std::uint32_t value, int n) {  // LSB first
    acc |= value << bits;
    bits += n;
    while (bits >= 8) out += static_cast<char>(acc & 0xff), acc >>= 8, bits -= 8;
  };
  // Huffman codes go most significant bit first: reversed here.
  auto put_code = [&](std::uint32_t code, int n) {
    std::uint32_t r = 0;
    for (int i = 0; i < n; ++i) r |= ((code >> i) & 1u) << (n - 1 - i);
    put(r, n);
  };
  put(1, 1);             // last block
  put(1, 2);             // fixed Huffman
  put_code(0x30, 8);     // literal 0
  std::size_t made = 1;
  while (made + 258 <= zeros) {
    put_code(0xc5, 8);   // length code 285: 258 bytes
    put_code(0, 5);      // distance code 0: distance 1
    made += 258;
  }
  while (made < zeros) put_code(0x30, 8), ++made;
  put_code(0, 7);        // end of block (code 256)
  if (bits) put(0, 8 - bits);
  const std::uint32_t adler = 1u | static_cast<std::uint32_t>(zeros % 65521) << 16;
  put_be32(out, adler);
  return out;
}

// A w x h test pattern of `c` 8-bit channels.
inline std::vector<unsigned char> test_pattern(int w, int h, int c) {
  std::vector<unsigned char> p(static_cast<std::size_t>(w) * h * c);
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = static_cast<unsigned char>((i * 37) % 256);
  return p;
}

// The file stb_image_write makes of test_pattern(w, h, c): "png", "bmp",
// "tga", "jpg" (quality 100) or "hdr".
inline std::string encoded_pattern(const std::string& format, int w, int h, int c) {
  std::string out;
  auto sink = [](void* ctx, void* data, int size) { static_cast<std::string*>(ctx)->append(static_cast<char*>(data), size); };
  const std::vector<unsigned char> p = test_pattern(w, h, c);
  if (format == "png") stbi_write_png_to_func(sink, &out, w, h, c, p.data(), w * c);
  if (format == "bmp") stbi_write_bmp_to_func(sink, &out, w, h, c, p.data());
  if (format == "tga") stbi_write_tga_to_func(sink, &out, w, h, c, p.data());
  if (format == "jpg") stbi_write_jpg_to_func(sink, &out, w, h, c, p.data(), 100);
  if (format == "hdr") {
    std::vector<float> f(p.begin(), p.end());
    stbi_write_hdr_to_func(sink, &out, w, h, c, f.data());
  }
  return out;
}

}  // namespace gr::testing
