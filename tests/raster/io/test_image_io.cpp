// Tests of raster/io/image_io.h: PNG round trips for 1 to 4 channels, float64 and
// H×W input, clamping, 16-bit files, errors on corrupt or missing files and bad
// shapes, and the atomic writers leaving no partial file.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/io/image_io.h"
#include "raster/image_bytes.h"
#include "raster/temp_dir.h"

using namespace gr;
using namespace gr::raster;
using gr::testing::put_be32;
using gr::testing::put_chunk;
using gr::testing::slurp;
using gr::testing::TempDir;

namespace {

// A one-row 16-bit greyscale PNG whose pixel data is a stored (uncompressed)
// deflate block.
std::string grey16_png(const std::vector<std::uint16_t>& row) {
  std::string ihdr;
  put_be32(ihdr, static_cast<std::uint32_t>(row.size()));
  put_be32(ihdr, 1);
  ihdr += std::string("\x10\x00\x00\x00\x00", 5);  // depth 16, grey, deflate, no filter/interlace
  std::string raw(1, '\0');                        // filter type 0
  for (std::uint16_t v : row) raw += {static_cast<char>(v >> 8), static_cast<char>(v & 0xff)};
  std::uint32_t a = 1, b = 0;
  for (unsigned char c : raw) a = (a + c) % 65521, b = (b + a) % 65521;
  const auto n = static_cast<std::uint16_t>(raw.size());
  std::string z = {'\x78', '\x01', '\x01', static_cast<char>(n & 0xff), static_cast<char>(n >> 8),
                   static_cast<char>(~n & 0xff), static_cast<char>((~n >> 8) & 0xff)};
  z += raw;
  put_be32(z, (b << 16) | a);
  std::string png = "\x89PNG\r\n\x1a\n";
  put_chunk(png, "IHDR", ihdr);
  put_chunk(png, "IDAT", z);
  put_chunk(png, "IEND", "");
  return png;
}

}  // namespace

TEST_CASE("write_png then read_image returns every 8-bit level for 1 to 4 channels", "[raster][io][image]") {
  TempDir dir;
  for (int c = 1; c <= 4; ++c) {
    INFO(c << " channels");
    // Values on the 8-bit grid, varying along rows, columns and channels.
    const int h = 5, w = 7;
    std::vector<float> v(h * w * c);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<float>((i * 37) % 256) / 255.0f;
    Tensor img = Tensor::from_vector(v, {h, w, c});
    write_png(dir.file("img.png"), img);
    Tensor back = read_image(dir.file("img.png"));
    REQUIRE(back.shape() == Shape{h, w, c});
    CHECK(back.dtype() == DType::Float32);
    CHECK(back.to_vector() == img.to_vector());
  }
  CHECK(dir.count() == 1);  // no temporaries left
}

TEST_CASE("write_png: row 0 is the top row of the file", "[raster][io][image]") {
  TempDir dir;
  Tensor img = Tensor::zeros({2, 1, 1});
  img.data<float>()[0] = 1.0f;  // top pixel white
  write_png(dir.file("top.png"), img);
  Tensor back = read_image(dir.file("top.png"));
  CHECK(back.at({0, 0, 0}) == 1.0f);
  CHECK(back.at({1, 0, 0}) == 0.0f);
}

TEST_CASE("write_png: float64 and H×W images are accepted, and values are clamped and rounded", "[raster][io][image]") {
  TempDir dir;
  Tensor img = Tensor::from_values({-0.5, 0.2, 1.7, std::nan(""), 0.5 / 255, 0.49 / 255}, {2, 3},
                                   DType::Float64);
  write_png(dir.file("grey.png"), img);
  Tensor back = read_image(dir.file("grey.png"));
  REQUIRE(back.shape() == Shape{2, 3, 1});
  std::vector<double> got = back.to_vector();
  CHECK(got[0] == 0.0);
  CHECK(got[1] == Approx(51.0 / 255));
  CHECK(got[2] == 1.0);
  CHECK(got[3] == 0.0);  // NaN writes black
  CHECK(got[4] == Approx(1.0 / 255));
  CHECK(got[5] == 0.0);
}

TEST_CASE("read_image: channel conversion and 16-bit PNGs", "[raster][io][image]") {
  TempDir dir;
  write_png(dir.file("rgb.png"), Tensor::full({3, 2, 3}, 1.0));
  Tensor rgba = read_image(dir.file("rgb.png"), 4);
  CHECK(rgba.shape() == Shape{3, 2, 4});
  CHECK(rgba.at({2, 1, 3}) == 1.0f);  // opaque alpha added
  CHECK(read_image(dir.file("rgb.png"), 1).shape() == Shape{3, 2, 1});
  CHECK_THROWS_AS(read_image(dir.file("rgb.png"), 5), ValueError);

  // A 16-bit greyscale PNG built by hand (stb writes only 8 bits): 1×2 pixels.
  const std::string png16 = grey16_png({0x0000, 0xffff});
  write_raw(dir.file("wide.png"), png16.data(), png16.size());
  Tensor wide = read_image(dir.file("wide.png"));
  REQUIRE(wide.shape() == Shape{1, 2, 1});
  CHECK(wide.at({0, 0, 0}) == 0.0f);
  CHECK(wide.at({0, 1, 0}) == 1.0f);
}

TEST_CASE("read_image: missing, truncated and corrupt files throw IOError naming the path", "[raster][io][image][errors]") {
  TempDir dir;
  CHECK_THROWS_WITH(read_image(dir.file("absent.png")),
                    Catch::Contains("absent.png") && Catch::Contains("No such file"));
  write_png(dir.file("ok.png"), Tensor::full({8, 8, 3}, 0.25));
  const std::string bytes = slurp(dir.file("ok.png"));
  // Truncated: header intact, data cut off.
  const std::string cut = dir.write("cut.png", bytes.substr(0, bytes.size() / 2));
  CHECK_THROWS_WITH(read_image(cut), Catch::Contains("cut.png"));
  CHECK_THROWS_AS(read_image(cut), IOError);
  // Not an image at all.
  const std::string text = dir.write("text.png", "this is not a png file");
  CHECK_THROWS_AS(read_image(text), IOError);
  // Empty file.
  CHECK_THROWS_AS(read_image(dir.write("empty.png", "")), IOError);
  // Corrupt compressed data behind a valid header and chunk layout.
  std::string bad = bytes;
  for (std::size_t i = 45; i < bad.size() - 20; ++i) bad[i] = static_cast<char>(0xa5);
  CHECK_THROWS_AS(read_image(dir.write("bad.png", bad)), IOError);
  CHECK_THROWS_AS(read_image(dir.path().string()), IOError);  // a directory
}

TEST_CASE("write_png rejects bad shapes and dtypes and leaves existing files alone", "[raster][io][image][errors]") {
  TempDir dir;
  const std::string path = dir.write("keep.png", "old");
  CHECK_THROWS_AS(write_png(path, Tensor::zeros({4})), ShapeError);
  CHECK_THROWS_AS(write_png(path, Tensor::zeros({2, 2, 5})), ShapeError);
  CHECK_THROWS_AS(write_png(path, Tensor::zeros({0, 2, 3})), ShapeError);
  CHECK_THROWS_AS(write_png(path, Tensor::zeros({1, 2, 2, 3})), ShapeError);
  CHECK_THROWS_AS(write_png(path, Tensor::zeros({2, 2, 3}, DType::Int32)), DTypeError);
  CHECK_THROWS_AS(write_png(path, Tensor()), ValueError);
  CHECK_THROWS_AS(write_png(dir.file("missing/dir/x.png"), Tensor::zeros({2, 2, 3})), IOError);
  CHECK(slurp(path) == "old");
  CHECK(dir.count() == 1);
}

TEST_CASE("write_raw replaces a file atomically and reports unwritable paths", "[raster][io][image]") {
  TempDir dir;
  const std::string path = dir.write("gbuf.bin", "previous");
  const float data[3] = {1.0f, -2.0f, 3.5f};
  write_raw(path, data, sizeof data);
  const std::string got = slurp(path);
  REQUIRE(got.size() == sizeof data);
  CHECK(std::memcmp(got.data(), data, sizeof data) == 0);
  write_raw(dir.file("empty.bin"), nullptr, 0);
  CHECK(slurp(dir.file("empty.bin")).empty());
  CHECK_THROWS_AS(write_raw(dir.file("nope/x.bin"), data, sizeof data), IOError);
  CHECK_THROWS_AS(write_raw(dir.path().string(), data, sizeof data), IOError);  // a directory
  CHECK(dir.count() == 2);
}

TEST_CASE("read_image: the documented formats load: PNG, BMP, TGA and JPEG in 1 to 4 channels", "[raster][io][image]") {
  TempDir dir;
  const int w = 5, h = 3;
  for (const char* format : {"png", "bmp", "tga", "jpg"}) {
    for (int c = 1; c <= 4; ++c) {
      // JPEG has no alpha; stb_image_write keeps a BMP's alpha only with 4 channels.
      if ((std::string(format) == "jpg" && (c == 2 || c == 4)) || (std::string(format) == "bmp" && c == 2)) continue;
      INFO(format << ", " << c << " channels");
      const std::string path = dir.write(std::string("pattern.") + format, gr::testing::encoded_pattern(format, w, h, c));
      const Tensor image = read_image(path, c);
      REQUIRE(image.shape() == Shape{h, w, c});
      const std::vector<unsigned char> expected = gr::testing::test_pattern(w, h, c);
      const std::vector<double> got = image.to_vector();
      // JPEG is lossy; the others give back every level.
      const double tolerance = std::string(format) == "jpg" ? 40.0 / 255 : 1e-6;
      for (std::size_t i = 0; i < got.size(); ++i) REQUIRE(std::abs(got[i] - expected[i] / 255.0) <= tolerance);
    }
  }
}
