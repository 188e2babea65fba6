// The Vulkan rasterizer gives the CPU kernel's G-buffer bit for bit (tri_id,
// u, v, depth as float32): on random triangle soups with near-plane crossings
// and depths beyond the clip range, on grids whose vertices and edges pass
// through pixel centres (the tie rule), on coplanar overlaps (the id rule), on
// large triangles (the per-workgroup path), on real meshes, with culling and
// nvdiffrast's row order; and depth peeling, layer by layer. Runs on whatever Device::open() finds (lavapipe in
// CI); without a Vulkan device each test says so and passes.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/procedural.h"
#include "raster/rasterize.h"
#include "raster/vulkan/rasterize.h"
#include "raster/kernel_checks.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

vulkan::Device* gpu() { return shared_gpu().get(); }

struct GBuffer {
  std::vector<std::int32_t> id;
  std::vector<float> uv, depth;
  explicit GBuffer(int W, int H) : id(W * H, -7), uv(2 * W * H, -7.f), depth(W * H, -7.f) {}
};

GBuffer on_cpu(const Scene& s, int W, int H, Cull cull = Cull::None) {
  GBuffer g(W, H);
  rasterize_forward(s.params(W, H, cull), g.id.data(), g.uv.data(), g.depth.data());
  return g;
}

GBuffer on_gpu(const Scene& s, int W, int H, Cull cull = Cull::None, bool y_up = false, int small_box = 64) {
  GBuffer g(W, H);
  vulkan::GpuRasterOptions options;
  options.y_up = y_up;
  options.small_box = small_box;
  vulkan::rasterize_forward(*gpu(), s.params(W, H, cull), g.id.data(), g.uv.data(), g.depth.data(), options);
  return g;
}

// Same bits everywhere (float compared as bits: -0 and NaN count).
template <class T>
std::int64_t differing(const std::vector<T>& a, const std::vector<T>& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(T)) != 0;
  return n;
}

void require_same(const GBuffer& gpu_g, const GBuffer& cpu_g) {
  std::int64_t covered = 0;
  for (std::int32_t t : cpu_g.id) covered += t > 0;
  INFO("pixels covered on the CPU: " << covered);
  CHECK(differing(gpu_g.id, cpu_g.id) == 0);
  CHECK(differing(gpu_g.uv, cpu_g.uv) == 0);
  CHECK(differing(gpu_g.depth, cpu_g.depth) == 0);
}

}  // namespace

TEST_CASE("the GPU G-buffer of random triangle soups is the CPU's bit for bit", "[vulkan]") {
  if (!gpu()) return;
  for (unsigned seed : {1u, 2u, 3u}) {
    const Scene s = random_soup(300, seed);
    for (auto [W, H] : {std::pair{64, 48}, std::pair{37, 91}}) {
      INFO("seed " << seed << ", " << W << "x" << H);
      require_same(on_gpu(s, W, H), on_cpu(s, W, H));
    }
  }
}

TEST_CASE("the GPU follows the CPU's tie rule on edges and vertices through pixel centres", "[vulkan]") {
  if (!gpu()) return;
  const Scene s = pixel_centre_grid(33, 8);
  const GBuffer cpu_g = on_cpu(s, 33, 33);
  require_same(on_gpu(s, 33, 33), cpu_g);
  // Every pixel is covered exactly once by the watertight grid.
  for (std::int32_t t : cpu_g.id) REQUIRE(t > 0);
}

TEST_CASE("the GPU gives coplanar overlaps to the smaller triangle index, as the CPU", "[vulkan]") {
  if (!gpu()) return;
  // Two identical full-screen pairs at one depth, listed in either order, and
  // one triangle at exactly that depth listed last: ties everywhere.
  Scene s;
  s.clip = {-1, -1, 0.5f, 1, 1, -1, 0.5f, 1, 1, 1, 0.5f, 1, -1, 1, 0.5f, 1};
  s.tris = {0, 1, 2, 0, 2, 3, 2, 1, 0, 3, 2, 0, 0, 1, 3};
  require_same(on_gpu(s, 70, 50), on_cpu(s, 70, 50));
}

TEST_CASE("the GPU's large-triangle path covers big boxes like the CPU", "[vulkan]") {
  if (!gpu()) return;
  // Few triangles, each larger than the per-thread limit, crossing each other in depth.
  const Scene s = random_soup(12, 9, 0.4);
  Scene big = s;
  for (std::size_t i = 0; i < big.clip.size(); i += 4) {
    big.clip[i] *= 4.0f;
    big.clip[i + 1] *= 4.0f;
  }
  const GBuffer cpu_g = on_cpu(big, 120, 100);
  // Every triangle per workgroup, every triangle per thread, and the default split.
  for (int small_box : {1, 64, 1 << 20}) {
    INFO("small_box " << small_box);
    require_same(on_gpu(big, 120, 100, Cull::None, false, small_box), cpu_g);
  }
}

TEST_CASE("the GPU G-buffer of real meshes, also crossing the near plane, is the CPU's", "[vulkan]") {
  if (!gpu()) return;
  const Mesh sphere = make_icosphere(4), torus = make_torus(48, 24);
  for (double distance : {3.0, 0.6}) {
    INFO("distance " << distance);
    require_same(on_gpu(perspective(sphere, 1.0, distance), 96, 80), on_cpu(perspective(sphere, 1.0, distance), 96, 80));
    require_same(on_gpu(perspective(torus, 1.0, distance), 80, 96), on_cpu(perspective(torus, 1.0, distance), 80, 96));
  }
}

TEST_CASE("the GPU clips near-plane crossings that round to w = 0 as the CPU", "[vulkan]") {
  if (!gpu()) return;
  // Positions of every float magnitude: the near clip's crossings round
  // anywhere, and the w >= eps clip then returns up to 6 vertices.
  for (unsigned seed = 0; seed < 3; ++seed) {
    INFO("seed " << seed);
    const Scene s{extreme_clip<float>(300, seed), random_triangles(2000, 300, seed + 1)};
    require_same(on_gpu(s, 16, 16), on_cpu(s, 16, 16));
  }
}

TEST_CASE("the GPU culls back and front faces as the CPU", "[vulkan]") {
  if (!gpu()) return;
  const Scene s = perspective(make_torus(32, 16), 1.0, 2.5);
  for (Cull cull : {Cull::Back, Cull::Front}) require_same(on_gpu(s, 64, 64, cull), on_cpu(s, 64, 64, cull));
}

TEST_CASE("the GPU's y_up rows are the CPU's on clip y negated", "[vulkan]") {
  if (!gpu()) return;
  const Scene s = random_soup(200, 5);
  Scene flipped = s;
  for (std::size_t i = 1; i < flipped.clip.size(); i += 4) flipped.clip[i] = -flipped.clip[i];
  require_same(on_gpu(s, 50, 40, Cull::None, true), on_cpu(flipped, 50, 40));
}

TEST_CASE("the GPU's RasterSettings::y_up is the CPU's y_up, and GpuRasterOptions::y_up's", "[vulkan][y_up]") {
  if (!gpu()) return;
  const Scene s = random_soup(200, 6);
  RasterParams<float> p = s.params(50, 40, Cull::None);
  p.settings.y_up = true;
  GBuffer by_settings(50, 40), on_cpu_up(50, 40);
  vulkan::rasterize_forward(*gpu(), p, by_settings.id.data(), by_settings.uv.data(), by_settings.depth.data());
  rasterize_forward(p, on_cpu_up.id.data(), on_cpu_up.uv.data(), on_cpu_up.depth.data());
  require_same(by_settings, on_cpu_up);
  require_same(by_settings, on_gpu(s, 50, 40, Cull::None, true));
  CHECK(differing(by_settings.id, on_cpu(s, 50, 40).id) > 0);
}

TEST_CASE("the GPU G-buffer is the same bits run after run", "[vulkan]") {
  if (!gpu()) return;
  const Scene s = perspective(make_icosphere(5), 1.0, 2.0);
  const GBuffer first = on_gpu(s, 128, 128);
  for (int run = 0; run < 3; ++run) {
    const GBuffer again = on_gpu(s, 128, 128);
    REQUIRE(differing(again.id, first.id) == 0);
    REQUIRE(differing(again.uv, first.uv) == 0);
    REQUIRE(differing(again.depth, first.depth) == 0);
  }
}

TEST_CASE("the GPU handles an empty mesh and a one-pixel image", "[vulkan]") {
  if (!gpu()) return;
  Scene empty;
  empty.clip = {0, 0, 0, 1};
  require_same(on_gpu(empty, 5, 3), on_cpu(empty, 5, 3));
  const Scene s = random_soup(50, 4);
  require_same(on_gpu(s, 1, 1), on_cpu(s, 1, 1));
}

namespace {

// Layers of a depth peel, each with the previous layer's key as its floor:
// the CPU kernel's, or the GPU's (each side peels from its own keys).
struct Layer {
  GBuffer g;
  std::vector<double> key;
  Layer(int W, int H) : g(W, H), key(std::size_t(W) * H, -7.0) {}
};

std::vector<Layer> peel(const Scene& s, int W, int H, int layers, bool on_device) {
  std::vector<Layer> out;
  for (int k = 0; k < layers; ++k) {
    Layer l(W, H);
    RasterParams<float> p = s.params(W, H);
    if (k > 0) {
      p.floor_id = out.back().g.id.data();
      p.floor_z = out.back().key.data();
    }
    if (on_device)
      vulkan::rasterize_forward(*gpu(), p, l.g.id.data(), l.g.uv.data(), l.g.depth.data(), {}, nullptr, l.key.data());
    else
      rasterize_forward(p, l.g.id.data(), l.g.uv.data(), l.g.depth.data(), nullptr, l.key.data());
    out.push_back(std::move(l));
  }
  return out;
}

}  // namespace

TEST_CASE("the GPU rasterizer peels depth layers as the CPU does, bit for bit, with key depths equal up to rounding", "[vulkan]") {
  if (!gpu()) return;
  Scene coplanar = pixel_centre_grid(24, 6);
  const Scene twice = coplanar;  // every triangle twice at the same depth: the id rule decides each layer
  for (std::size_t i = 0; i < twice.tris.size(); ++i)
    coplanar.tris.push_back(twice.tris[i]);
  const std::vector<std::pair<const char*, Scene>> scenes = {
      {"random soup", random_soup(200, 9)}, {"coplanar duplicates", coplanar}, {"slivers", slivers(60, 4)}};
  for (const auto& named : scenes) {
    const Scene& s = named.second;
    const int W = 40, H = 33;
    const std::vector<Layer> cpu = peel(s, W, H, 5, false), dev = peel(s, W, H, 5, true);
    for (int k = 0; k < 5; ++k) {
      INFO(named.first << ", layer " << k);
      require_same(dev[std::size_t(k)].g, cpu[std::size_t(k)].g);
      // The same depths up to rounding (measured: a few ulps of the terms, which
      // slivers make large; the float depths above agree bit for bit). Each
      // side peels from its own keys.
      std::int64_t keys_differ = 0;
      for (std::size_t i = 0; i < cpu[std::size_t(k)].key.size(); ++i) {
        const double a = dev[std::size_t(k)].key[i], b = cpu[std::size_t(k)].key[i];
        keys_differ += !(a == b || std::abs(a - b) <= 1e-12);
      }
      CHECK(keys_differ == 0);
    }
    std::int64_t second = 0;
    for (std::int32_t t : cpu[1].g.id) second += t > 0;
    INFO(named.first);
    CHECK(second > 0);  // a second layer exists, so the floors were used
  }
}

TEST_CASE("the GPU rasterizer refuses half a peeling floor and a small_box below 1", "[vulkan]") {
  if (!gpu()) return;
  const Scene s = random_soup(4, 6);
  std::vector<std::int32_t> floor_id(16, 0);
  RasterParams<float> p = s.params(4, 4);
  p.floor_id = floor_id.data();
  GBuffer g(4, 4);
  REQUIRE_THROWS_WITH(vulkan::rasterize_forward(*gpu(), p, g.id.data(), g.uv.data(), g.depth.data()),
                      Catch::Contains("floor_id and floor_z"));
  vulkan::GpuRasterOptions bad;
  bad.small_box = 0;
  REQUIRE_THROWS_WITH(vulkan::rasterize_forward(*gpu(), s.params(4, 4), g.id.data(), g.uv.data(), g.depth.data(), bad),
                      Catch::Contains("small_box"));
}

TEST_CASE("Device::open says why when GRADRASTER_VULKAN_DEVICE names no device", "[vulkan]") {
  if (!gpu()) return;
  const char* old = std::getenv("GRADRASTER_VULKAN_DEVICE");
  const std::string saved = old ? old : "";
  setenv("GRADRASTER_VULKAN_DEVICE", "no such device 7f3a", 1);
  std::string why;
  const auto none = vulkan::Device::open(&why);
  if (old)
    setenv("GRADRASTER_VULKAN_DEVICE", saved.c_str(), 1);
  else
    unsetenv("GRADRASTER_VULKAN_DEVICE");
  CHECK(none == nullptr);
  CHECK_THAT(why, Catch::Contains("no such device 7f3a") && Catch::Contains(gpu()->info().name));
}

TEST_CASE("the GPU rasterizer refuses bad input with an error naming it", "[vulkan]") {
  if (!gpu()) return;
  Scene s = random_soup(4, 8);
  GBuffer g(8, 8);
  auto call = [&](const RasterParams<float>& p) {
    vulkan::rasterize_forward(*gpu(), p, g.id.data(), g.uv.data(), g.depth.data());
  };
  s.tris[5] = 12;  // 12 vertices: indices 0..11
  REQUIRE_THROWS_WITH(call(s.params(8, 8)), Catch::Contains("tris[1][2] = 12"));
  s.tris[5] = -1;
  REQUIRE_THROWS_AS(call(s.params(8, 8)), IndexError);
  s.tris[5] = 5;
  s.clip[6] = std::nanf("");
  REQUIRE_THROWS_WITH(call(s.params(8, 8)), Catch::Contains("clip[6] is NaN or Inf"));
  s.clip[6] = 0.5f;
  REQUIRE_THROWS_WITH(call(s.params(0, 8)), Catch::Contains("image size"));
  REQUIRE_THROWS_WITH(call(s.params(16385, 8)), Catch::Contains("image size"));
  RasterParams<float> huge = s.params(8, 8);
  huge.num_tris = std::int64_t(1) << 30;
  REQUIRE_THROWS_WITH(call(huge), Catch::Contains("triangles"));
  call(s.params(8, 8));  // and the device still works
}
