// Tests of raster/io/image_decoder.h: every decode stays inside the memory
// budget, and sizes the decoder cannot handle are named, not reported as an
// unknown image type (issue 30).
#include <catch2/catch.hpp>

#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "raster/image_bytes.h"
#include "raster/io/image_io.h"
#include "raster/temp_dir.h"

using namespace gr;
using namespace gr::raster;
using gr::testing::png_file;
using gr::testing::TempDir;
using gr::testing::zlib_of_zeros;

namespace {

// Restores the default memory limit when a test ends, also by an exception.
struct MemoryLimit {
  explicit MemoryLimit(std::size_t bytes_free) { set_memory_limit(memory_in_use() + bytes_free); }
  ~MemoryLimit() { set_memory_limit(0); }
};

}  // namespace

TEST_CASE("read_image: a PNG whose data expands far beyond its header is stopped at the memory budget",
          "[raster][io][image][memory]") {
  TempDir dir;
  // 16 x 16 grey pixels need 272 bytes of image data; this IDAT inflates to
  // 48 MiB from 300 KB (stb_image inflated all of it, outside the budget).
  const std::string bomb = png_file(16, 16, 0, zlib_of_zeros(std::size_t(48) << 20));
  REQUIRE(bomb.size() < 400000);
  const std::string path = dir.write("bomb.png", bomb);
  {
    MemoryLimit limit(std::size_t(16) << 20);
    CHECK_THROWS_WITH(read_image(path), Catch::Contains("bomb.png") && Catch::Contains("16 x 16") &&
                                            Catch::Contains("memory budget"));
    CHECK_THROWS_AS(read_image(path), MemoryError);
  }
  // Within the default budget the decode completes: the first 272 bytes are the image.
  const Tensor image = read_image(path);
  CHECK(image.shape() == Shape{16, 16, 1});
  // The same image with only its own data loads under the small budget.
  MemoryLimit limit(std::size_t(16) << 20);
  CHECK(read_image(dir.write("plain.png", png_file(16, 16, 0, zlib_of_zeros(16 * 17)))).shape() == Shape{16, 16, 1});
}

TEST_CASE("read_image: a PNG whose header claims more than 1 GiB decoded is refused naming its size",
          "[raster][io][image][errors]") {
  TempDir dir;
  // 20000 x 20000 RGB: 1.2 GB decoded, sides within the limit. stb_image
  // refuses it before saying why; it was reported as "unknown image type".
  const std::string path = dir.write("poster.png", png_file(20000, 20000, 2, zlib_of_zeros(1000)));
  CHECK_THROWS_WITH(read_image(path), Catch::Contains("poster.png") && Catch::Contains("20000 x 20000") &&
                                          Catch::Contains("3 channels") && Catch::Contains("1200000000 bytes") &&
                                          Catch::Contains("1 GiB") && !Catch::Contains("unknown image type"));
  CHECK_THROWS_AS(read_image(path), IOError);
  // 16-bit samples count twice: 16384 x 16384 RGBA is 2 GiB (stb's own test passes it).
  CHECK_THROWS_WITH(read_image(dir.write("deep.png", png_file(16384, 16384, 6, zlib_of_zeros(1000), 16))),
                    Catch::Contains("deep.png") && Catch::Contains("16384 x 16384") &&
                        Catch::Contains("4 channels of 16 bits") && Catch::Contains("1 GiB"));
  // Asking for more channels than the file has counts the channels asked for.
  CHECK_THROWS_WITH(read_image(dir.write("grey.png", png_file(32768, 16384, 0, zlib_of_zeros(1000))), 3),
                    Catch::Contains("32768 x 16384") && Catch::Contains("3 channels"));
}
