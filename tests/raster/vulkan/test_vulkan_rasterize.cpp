// The Vulkan rasterizer gives the CPU kernel's G-buffer bit for bit (tri_id,
// u, v, depth as float32): on random triangle soups with near-plane crossings
// and depths beyond the clip range, on grids whose vertices and edges pass
// through pixel centres (the tie rule), on coplanar overlaps (the id rule), on
// large triangles (the per-workgroup path), on real meshes, with culling and
// nvdiffrast's row order. Runs on whatever Device::open() finds (lavapipe in
// CI); without a Vulkan device each test says so and passes.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "autodiff/error.h"
#include "raster/procedural.h"
#include "raster/rasterize.h"
#include "raster/vulkan/rasterize.h"

using namespace gr;
using namespace gr::raster;

namespace {

vulkan::Device* gpu() {
  static std::string why;
  static std::shared_ptr<vulkan::Device> device = vulkan::Device::open(&why);
  if (!device) WARN("no Vulkan device, GPU test skipped: " << why);
  return device.get();
}

struct GBuffer {
  std::vector<std::int32_t> id;
  std::vector<float> uv, depth;
  explicit GBuffer(int W, int H) : id(W * H, -7), uv(2 * W * H, -7.f), depth(W * H, -7.f) {}
};

struct Scene {
  std::vector<float> clip;
  std::vector<std::int32_t> tris;
  RasterParams<float> params(int W, int H, Cull cull = Cull::None) const {
    return {clip.data(), static_cast<std::int64_t>(clip.size() / 4), tris.data(),
            static_cast<std::int64_t>(tris.size() / 3), RasterSettings{W, H, cull}};
  }
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

// Random triangles: vertices anywhere around the view, w in [-0.5, 2] (some
// behind the camera, so triangles cross the near plane), z beyond [-w, w] too.
Scene random_soup(int triangles, unsigned seed, double spread = 1.3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-spread, spread), zz(-1.3, 1.3), ww(-0.5, 2.0), jitter(-0.15, 0.15);
  Scene s;
  for (int t = 0; t < triangles; ++t) {
    const double cx = xy(rng), cy = xy(rng), cz = zz(rng), cw = ww(rng);
    for (int k = 0; k < 3; ++k) {
      const double w = cw + 0.3 * jitter(rng);
      s.clip.insert(s.clip.end(), {float((cx + jitter(rng)) * std::abs(w)), float((cy + jitter(rng)) * std::abs(w)),
                                   float((cz + jitter(rng)) * w), float(w)});
      s.tris.push_back(3 * t + k);
    }
  }
  return s;
}

// A grid of n x n quads whose vertices lie on pixel centres of a W x W image
// (every diagonal passes through centres): the tie rule decides most pixels.
Scene pixel_centre_grid(int W, int n) {
  Scene s;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double px = 0.5 + (W - 1.0) * i / n, py = 0.5 + (W - 1.0) * j / n;
      s.clip.insert(s.clip.end(), {float(2.0 * px / W - 1.0), float(1.0 - 2.0 * py / W), 0.25f, 1.0f});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::int32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      s.tris.insert(s.tris.end(), {a, b, d, a, d, c});
    }
  return s;
}

// A mesh in perspective: positions scaled and moved `distance` in front of
// the camera (w = distance - z), so that a small distance puts part of it behind.
Scene perspective(const Mesh& m, double scale, double distance) {
  Scene s;
  const float* p = m.positions.data<float>();
  for (std::int64_t i = 0; i < m.num_vertices(); ++i) {
    const double x = scale * p[3 * i], y = scale * p[3 * i + 1], z = scale * p[3 * i + 2];
    const double w = distance - z;
    s.clip.insert(s.clip.end(), {float(1.2 * x), float(1.2 * y), float(1.02 * w - 0.2), float(w)});
  }
  const std::int32_t* t = m.triangles.data<std::int32_t>();
  s.tris.assign(t, t + 3 * m.num_triangles());
  return s;
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

TEST_CASE("the GPU rasterizer refuses depth peeling (not on the GPU yet) and a small_box below 1", "[vulkan]") {
  if (!gpu()) return;
  const Scene s = random_soup(4, 6);
  std::vector<std::int32_t> floor_id(16, 0);
  std::vector<double> floor_z(16, 0.0);
  RasterParams<float> p = s.params(4, 4);
  p.floor_id = floor_id.data();
  p.floor_z = floor_z.data();
  GBuffer g(4, 4);
  REQUIRE_THROWS_AS(vulkan::rasterize_forward(*gpu(), p, g.id.data(), g.uv.data(), g.depth.data()), ValueError);
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
