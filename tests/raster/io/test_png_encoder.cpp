// Tests of raster/io/png_encoder.h: files that an independent decoder (stb_image)
// reads back to the same samples for every channel count and odd sizes, the
// chunk layout with CRCs checked by a bitwise CRC-32, and the Up filter on
// every row of the inflated data.
#include <catch2/catch.hpp>
#include <zlib.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "raster/image_bytes.h"
#include "raster/io/image_io.h"
#include "raster/io/png_encoder.h"

using namespace gr;
using namespace gr::raster;

namespace {

std::vector<std::uint8_t> random_levels(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> level(0, 255);
  std::vector<std::uint8_t> out(n);
  for (auto& v : out) v = static_cast<std::uint8_t>(level(rng));
  return out;
}

std::uint32_t be32(const std::vector<unsigned char>& b, std::size_t at) {
  return std::uint32_t(b[at]) << 24 | std::uint32_t(b[at + 1]) << 16 | std::uint32_t(b[at + 2]) << 8 | b[at + 3];
}

struct Chunk {
  std::string type;
  std::vector<unsigned char> data;
};

// The chunks after the signature, each CRC checked.
std::vector<Chunk> chunks_of(const std::vector<unsigned char>& png) {
  std::vector<Chunk> chunks;
  std::size_t at = 8;
  while (at < png.size()) {
    REQUIRE(at + 12 <= png.size());
    const std::uint32_t size = be32(png, at);
    REQUIRE(at + 12 + size <= png.size());
    Chunk chunk{std::string(png.begin() + at + 4, png.begin() + at + 8),
                std::vector<unsigned char>(png.begin() + at + 8, png.begin() + at + 8 + size)};
    const std::string crc_input(png.begin() + at + 4, png.begin() + at + 8 + size);
    CHECK(be32(png, at + 8 + size) == gr::testing::crc32(crc_input));
    chunks.push_back(chunk);
    at += 12 + size;
  }
  return chunks;
}

}  // namespace

TEST_CASE("png encoder: every channel count and odd size decodes back to the same levels", "[image]") {
  for (int channels = 1; channels <= 4; ++channels) {
    for (auto [h, w] : {std::pair<int, int>{1, 1}, {3, 7}, {65, 33}, {2, 300}}) {
      const auto levels = random_levels(std::size_t(h) * w * channels, 7 * channels + h);
      const auto png = encode_png_levels(levels.data(), h, w, channels, "test");
      const Tensor image = read_image_from_memory(std::string(png.begin(), png.end()), "test.png");
      REQUIRE(image.size(0) == h);
      REQUIRE(image.size(1) == w);
      REQUIRE(image.size(2) == channels);
      const float* got = image.data<float>();
      std::size_t wrong = 0;
      for (std::size_t i = 0; i < levels.size(); ++i) wrong += got[i] != levels[i] / 255.0f;
      CHECK(wrong == 0);
    }
  }
}

TEST_CASE("png encoder: a file is the signature, IHDR, IDAT and IEND, with correct CRCs", "[image]") {
  const auto levels = random_levels(5 * 9 * 3, 1);
  const auto png = encode_png_levels(levels.data(), 5, 9, 3, "test");
  REQUIRE(png.size() > 8);
  CHECK(std::vector<unsigned char>(png.begin(), png.begin() + 8) ==
        std::vector<unsigned char>{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'});
  const auto chunks = chunks_of(png);
  REQUIRE(chunks.size() == 3);
  CHECK(chunks[0].type == "IHDR");
  CHECK(chunks[1].type == "IDAT");
  CHECK(chunks[2].type == "IEND");
  CHECK(chunks[2].data.empty());
  const auto& ihdr = chunks[0].data;
  REQUIRE(ihdr.size() == 13);
  CHECK(be32(ihdr, 0) == 9);  // width
  CHECK(be32(ihdr, 4) == 5);  // height
  CHECK(std::vector<unsigned char>(ihdr.begin() + 8, ihdr.end()) == std::vector<unsigned char>{8, 2, 0, 0, 0});

  // Grey, grey + alpha and RGBA have colour types 0, 4 and 6.
  for (auto [channels, type] : {std::pair<int, int>{1, 0}, {2, 4}, {4, 6}}) {
    const auto png_c = encode_png_levels(random_levels(4 * channels, 2).data(), 2, 2, channels, "test");
    CHECK(int(chunks_of(png_c)[0].data[9]) == type);
  }
}

TEST_CASE("png encoder: every row is stored with the Up filter, the first as is", "[image]") {
  const int h = 6, w = 11, channels = 3;
  const std::size_t stride = w * channels;
  const auto levels = random_levels(h * stride, 3);
  const auto chunks = chunks_of(encode_png_levels(levels.data(), h, w, channels, "test"));
  std::vector<unsigned char> raw(h * (1 + stride));
  uLongf size = raw.size();
  REQUIRE(uncompress(raw.data(), &size, chunks[1].data.data(), chunks[1].data.size()) == Z_OK);
  REQUIRE(size == raw.size());
  for (int y = 0; y < h; ++y) {
    const unsigned char* row = raw.data() + y * (1 + stride);
    CHECK(int(row[0]) == 2);
    for (std::size_t i = 0; i < stride; ++i) {
      const int above = y ? levels[(y - 1) * stride + i] : 0;
      REQUIRE(int(row[1 + i]) == ((levels[y * stride + i] - above) & 0xff));
    }
  }
}
