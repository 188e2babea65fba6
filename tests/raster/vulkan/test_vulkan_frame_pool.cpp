// FramePool (raster/vulkan/frame_pool.h): which frame a new G-buffer takes
// and which G-buffers stay findable.
#include <catch2/catch.hpp>

#include <memory>

#include "raster/vulkan/frame_pool.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::testing;

TEST_CASE("a frame pool keeps the G-buffers still held and lets the least recently used go first", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::FramePool pool(shared_gpu(), 2);
  auto a = std::make_shared<int>(1), b = std::make_shared<int>(2), c = std::make_shared<int>(3);
  vulkan::Frame& fa = pool.take();
  pool.tag(fa, 1, a);
  vulkan::Frame& fb = pool.take();
  pool.tag(fb, 2, b);
  CHECK(&fa != &fb);
  CHECK(pool.frames() == 2);
  CHECK(pool.find(1) == &fa);  // a is now the most recently used
  SECTION("a full pool gives the least recently used frame") {
    vulkan::Frame& fc = pool.take();
    pool.tag(fc, 3, c);
    CHECK(&fc == &fb);
    CHECK(pool.find(2) == nullptr);
    CHECK(pool.find(3) == &fb);
    CHECK(pool.find(1) == &fa);
    CHECK(pool.frames() == 2);
  }
  SECTION("a frame whose holder is gone is taken first, and its G-buffer is not found") {
    a.reset();
    CHECK(pool.find(1) == nullptr);
    CHECK(&pool.take() == &fa);
    CHECK(pool.find(2) == &fb);
  }
  SECTION("an untagged frame is taken before a held one") {
    vulkan::Frame& loaded = pool.take();  // b's frame, the least recently used, left untagged
    CHECK(&loaded == &fb);
    CHECK(pool.find(2) == nullptr);
    CHECK(&pool.take() == &fb);
    CHECK(pool.find(1) == &fa);
  }
  CHECK(pool.find(0) == nullptr);
}

TEST_CASE("a frame pool reserved for more frames makes them before letting a held one go", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::FramePool pool(shared_gpu(), 1);
  auto a = std::make_shared<int>(1), b = std::make_shared<int>(2);
  vulkan::Frame& fa = pool.take();
  pool.tag(fa, 1, a);
  pool.reserve(2);
  pool.reserve(1);  // never fewer
  CHECK(pool.capacity() == 2);
  vulkan::Frame& fb = pool.take();
  pool.tag(fb, 2, b);
  CHECK(&fb != &fa);
  CHECK(pool.find(1) == &fa);
  CHECK(pool.find(2) == &fb);
}

TEST_CASE("a frame pool refuses a capacity below one, naming it", "[vulkan]") {
  if (!shared_gpu()) return;
  CHECK_THROWS_WITH(vulkan::FramePool(shared_gpu(), 0), Catch::Contains("capacity"));
}
