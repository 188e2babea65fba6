// Tests of raster/io/jpeg_check.h: a JPEG Huffman table with more than 256 codes,
// which stb_image 2.27 wrote past its table for (found by fuzz_image), is
// refused before the decoder runs; ordinary JPEGs pass.
#include <catch2/catch.hpp>

#include <string>

#include "autodiff/base/error.h"
#include "raster/image_bytes.h"
#include "raster/io/image_io.h"
#include "raster/io/jpeg_check.h"

using namespace gr;
using namespace gr::raster;
using gr::testing::encoded_pattern;

namespace {

// The offset of the first DHT segment's first table in a JPEG.
std::size_t first_huffman_table(const std::string& jpeg) {
  const std::size_t at = jpeg.find("\xff\xc4");
  REQUIRE(at != std::string::npos);
  return at + 4;
}

}  // namespace

TEST_CASE("read_image: a JPEG Huffman table of more than 256 codes is refused before decoding", "[raster][io][image][errors]") {
  std::string jpeg = encoded_pattern("jpg", 16, 16, 3);
  REQUIRE_NOTHROW(check_jpeg_huffman_tables(jpeg, "x"));
  // The last of the first table's 16 code counts raised to 255.
  jpeg[first_huffman_table(jpeg) + 16] = '\xff';
  CHECK_THROWS_WITH(read_image_from_memory(jpeg, "tables.jpg"),
                    Catch::Contains("tables.jpg") && Catch::Contains("Huffman table") && Catch::Contains("at most 256"));
  CHECK_THROWS_AS(read_image_from_memory(jpeg, "tables.jpg"), IOError);
}

TEST_CASE("read_image: a JPEG Huffman table read past its segment is checked as the decoder reads it", "[raster][io][image][errors]") {
  // A DHT segment of 18 bytes: one empty table (17 bytes) and one byte left,
  // so the decoder reads a second table from the bytes after the segment,
  // whose counts (all 255) define 4080 codes.
  const std::string jpeg = std::string("\xff\xd8\xff\xc4\x00\x14\x00", 7) + std::string(16, '\0') + std::string(1, '\0') +
                           std::string(16, '\xff') + std::string(64, '\0') + "\xff\xd9";
  CHECK_THROWS_WITH(read_image_from_memory(jpeg, "past.jpg"),
                    Catch::Contains("past.jpg") && Catch::Contains("4080 codes"));
  // Cut by the end of the file: the missing counts read as 0, as in the
  // decoder; two counts of 255 are too many, one is not (the decoder then
  // finds the file truncated).
  CHECK_THROWS_WITH(check_jpeg_huffman_tables(jpeg.substr(0, 7 + 16 + 1 + 2), "cut.jpg"), Catch::Contains("510 codes"));
  const std::string cut = jpeg.substr(0, 7 + 16 + 1 + 1);
  CHECK_NOTHROW(check_jpeg_huffman_tables(cut, "cut.jpg"));
  CHECK_THROWS_WITH(read_image_from_memory(cut, "cut.jpg"), Catch::Contains("cut.jpg") && Catch::Contains("corrupt"));
}
