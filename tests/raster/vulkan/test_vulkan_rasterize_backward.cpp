// The GPU's rasterize adjoint (raster/vulkan/frame.h) against the CPU kernel
// (raster::rasterize_backward) for the same coverage: dL/dclip within 1e-5
// relative to the largest, through u, v and depth, on soups crossing the near
// plane (the homogeneous form), meshes and nvdiffrast's row order; the same
// bits run after run; accumulation (+=).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "raster/procedural.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

struct Grads {
  std::vector<float> uv, depth;
};

std::vector<float> on_cpu(const Scene& s, int W, int H, bool y_up, const Grads& g, bool with_depth) {
  Scene flipped = s;
  if (y_up)
    for (std::size_t i = 1; i < flipped.clip.size(); i += 4) flipped.clip[i] = -flipped.clip[i];
  const std::int64_t px = std::int64_t(W) * H;
  std::vector<std::int32_t> id(px);
  std::vector<float> uv(2 * px), depth(px), grad(s.clip.size(), 0.0f);
  rasterize_forward(flipped.params(W, H), id.data(), uv.data(), depth.data());
  rasterize_backward(flipped.params(W, H), id.data(), g.uv.data(), with_depth ? g.depth.data() : nullptr,
                     grad.data());
  if (y_up)
    for (std::size_t i = 1; i < grad.size(); i += 4) grad[i] = -grad[i];
  return grad;
}

std::vector<float> on_gpu(vulkan::Frame& frame, const Scene& s, int W, int H, bool y_up, const Grads& g,
                          bool with_depth) {
  vulkan::GpuRasterOptions options;
  options.y_up = y_up;
  frame.rasterize(s.params(W, H), options);
  std::vector<float> grad(s.clip.size(), 0.0f);
  frame.rasterize_backward(g.uv.data(), with_depth ? g.depth.data() : nullptr, grad.data());
  return grad;
}

void check_scene(const Scene& s, int W, int H, bool y_up, unsigned seed) {
  const std::int64_t px = std::int64_t(W) * H;
  const Grads g{random_values(2 * px, seed), random_values(px, seed + 1)};
  vulkan::Frame frame(shared_gpu());
  for (bool with_depth : {false, true}) {
    INFO("grad_depth " << with_depth << ", y_up " << y_up);
    const std::vector<float> cpu = on_cpu(s, W, H, y_up, g, with_depth);
    double largest = 0.0;
    for (float x : cpu) largest = std::max(largest, double(std::abs(x)));
    REQUIRE(largest > 0.0);
    CHECK(relative_error(on_gpu(frame, s, W, H, y_up, g, with_depth), cpu) <= 1e-5);
  }
}

}  // namespace

TEST_CASE("GPU rasterize adjoint matches the CPU on soups crossing the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  check_scene(random_soup(200, 31), 64, 48, false, 1);
  check_scene(random_soup(200, 32), 48, 64, true, 2);
}

TEST_CASE("GPU rasterize adjoint matches the CPU on meshes in front of and through the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  check_scene(perspective(make_icosphere(3), 1.0, 3.0), 80, 72, false, 3);
  check_scene(perspective(make_torus(40, 20), 1.0, 0.6), 80, 72, false, 4);
}

TEST_CASE("GPU rasterize adjoint is the same bits every run and accumulates", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = perspective(make_icosphere(4), 1.0, 2.0);
  const Grads g{random_values(2 * 96 * 96, 5), random_values(96 * 96, 6)};
  vulkan::Frame frame(shared_gpu());
  const std::vector<float> first = on_gpu(frame, s, 96, 96, false, g, true);
  for (int run = 0; run < 3; ++run)
    REQUIRE(std::memcmp(on_gpu(frame, s, 96, 96, false, g, true).data(), first.data(), first.size() * 4) == 0);
  std::vector<float> grad(s.clip.size(), 2.0f);
  frame.rasterize_backward(g.uv.data(), g.depth.data(), grad.data());
  for (std::size_t i = 0; i < grad.size(); ++i) REQUIRE(grad[i] == 2.0f + first[i]);
}

TEST_CASE("GPU rasterize and its adjoint report their passes' times", "[vulkan]") {
  if (!shared_gpu() || shared_gpu()->info().timestamp_period_ns <= 0.0) return;
  const Scene s = random_soup(50, 3);
  vulkan::Frame frame(shared_gpu());
  CHECK(frame.rasterize(s.params(32, 32)).pass_ms.size() == 5);
  const std::vector<float> grad = random_values(32 * 32 * 2, 2);
  std::vector<float> grad_clip(s.clip.size());
  CHECK(frame.rasterize_backward(grad.data(), nullptr, grad_clip.data()).pass_ms.size() == 3);
}
