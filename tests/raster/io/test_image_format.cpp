// Tests of raster/io/image_format.h: the formats read_image accepts are told by
// their first bytes, and every other format is refused, named, before any
// decoder runs (issue 30: a truncated Radiance HDR file hung the decoder).
#include <catch2/catch.hpp>

#include <chrono>
#include <string>

#include "autodiff/base/error.h"
#include "raster/io/image_format.h"
#include "raster/image_bytes.h"
#include "raster/io/image_io.h"
#include "raster/temp_dir.h"

using namespace gr;
using namespace gr::raster;
using gr::testing::encoded_pattern;
using gr::testing::TempDir;

TEST_CASE("identify_image_format: PNG, JPEG, BMP and TGA files are told by their first bytes", "[raster][io][image]") {
  CHECK(identify_image_format(encoded_pattern("png", 4, 3, 3), "x") == ImageFormat::Png);
  CHECK(identify_image_format(encoded_pattern("jpg", 4, 3, 3), "x") == ImageFormat::Jpeg);
  CHECK(identify_image_format(encoded_pattern("bmp", 4, 3, 3), "x") == ImageFormat::Bmp);
  CHECK(identify_image_format(encoded_pattern("tga", 4, 3, 1), "x") == ImageFormat::Tga);
  CHECK(identify_image_format(encoded_pattern("tga", 4, 3, 4), "x") == ImageFormat::Tga);
  CHECK(std::string(image_format_name(ImageFormat::Tga)) == "TGA");
}

TEST_CASE("read_image: a truncated Radiance HDR file, a GIF, a PNM and a PSD are refused at once, naming the file and the format",
          "[raster][io][image][errors]") {
  TempDir dir;
  const std::string hdr = encoded_pattern("hdr", 8, 8, 3);
  REQUIRE(hdr.size() > 60);
  struct Case {
    std::string name, bytes, format;
  };
  const Case cases[] = {
      // Cut in the first run-length-encoded scanline: stb_image's decoder
      // looped forever on it (issue 30: a 51-byte file hung gradraster-fit).
      {"cut.hdr", std::string("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 8\n\x02\x02\x00\x08", 49), "Radiance HDR"},
      {"whole.hdr", hdr, "Radiance HDR"},
      {"dot.gif", std::string("GIF89a\x01\x00\x01\x00\x80\x00\x00\x00\x00\x00\xff\xff\xff,\x00\x00\x00\x00\x01\x00\x01"
                              "\x00\x00\x02\x02\x44\x01\x00;", 35),
       "GIF"},
      {"dot.ppm", std::string("P6\n1 1\n255\n\xff\x00\x00", 14), "PNM"},
      {"dot.pgm", std::string("P5 1 1 255 \x80", 12), "PNM"},
      {"dot.psd", std::string("8BPS\x00\x01\x00\x00\x00\x00\x00\x00\x00\x03\x00\x00\x00\x01\x00\x00\x00\x01\x00\x08\x00\x03", 26),
       "Photoshop PSD"},
  };
  const auto start = std::chrono::steady_clock::now();
  for (const Case& c : cases) {
    INFO(c.name);
    const std::string path = dir.write(c.name, c.bytes);
    CHECK_THROWS_WITH(read_image(path), Catch::Contains(c.name) && Catch::Contains(c.format) &&
                                            Catch::Contains("only PNG, JPEG, BMP and TGA"));
    CHECK_THROWS_AS(read_image(path), IOError);
  }
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(2));
}

TEST_CASE("read_image: bytes of no known image format are refused, quoting their start", "[raster][io][image][errors]") {
  TempDir dir;
  CHECK_THROWS_WITH(read_image(dir.write("notes.png", "hello, world")),
                    Catch::Contains("notes.png") && Catch::Contains("not a PNG, JPEG, BMP or TGA image") &&
                        Catch::Contains("'hello, w'"));
  CHECK_THROWS_WITH(read_image(dir.write("empty.png", "")), Catch::Contains("empty.png") && Catch::Contains("empty"));
  // Shorter than a WebP header (found by fuzz_image: the format check read past the end).
  CHECK_THROWS_WITH(read_image(dir.write("short.webp", "RIFFPF~")), Catch::Contains("short.webp") && Catch::Contains("not a PNG"));
  CHECK_THROWS_WITH(read_image(dir.write("long.webp", std::string("RIFF\0\0\0\0WEBPVP8 ", 16))),
                    Catch::Contains("long.webp") && Catch::Contains("WebP"));
  // A TGA header whose image type no TGA has.
  std::string tga = encoded_pattern("tga", 2, 2, 3);
  tga[2] = 7;
  CHECK_THROWS_WITH(read_image(dir.write("odd.tga", tga)), Catch::Contains("odd.tga") && Catch::Contains("not a PNG"));
}
