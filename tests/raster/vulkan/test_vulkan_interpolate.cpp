// The GPU's interpolate and its adjoint (raster/vulkan/frame.h) against the
// CPU kernels (raster/interpolate.h) on the same G-buffer: values within 1e-6
// and gradients (attributes, clip w and, for clipped triangles, x and y; u, v)
// within 1e-5 relative to the largest, on random soups crossing the near
// plane, meshes, 1 to 5 channels, perspective and linear weights and
// nvdiffrast's row order; the same bits run after run; accumulation (+=).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/interpolate.h"
#include "raster/procedural.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

struct Case {
  Scene scene;
  int W, H;
  std::int64_t C;
  bool perspective = true, y_up = false;
};

struct Result {
  std::vector<float> out, grad_attr, grad_clip, grad_uv;
};

// The CPU kernels on the CPU's G-buffer (with y_up: of the clip with y negated).
Result on_cpu(const Case& c, const std::vector<float>& attr, const std::vector<float>& grad_out) {
  const std::int64_t N = static_cast<std::int64_t>(c.scene.clip.size() / 4), px = std::int64_t(c.W) * c.H;
  std::vector<float> clip = c.scene.clip;
  if (c.y_up)
    for (std::size_t i = 1; i < clip.size(); i += 4) clip[i] = -clip[i];
  Scene flipped = c.scene;
  flipped.clip = clip;
  std::vector<std::int32_t> id(px);
  std::vector<float> uv(2 * px), depth(px);
  rasterize_forward(flipped.params(c.W, c.H), id.data(), uv.data(), depth.data());
  InterpolateParams<float> p;
  p.attr = attr.data();
  p.num_vertices = N;
  p.channels = c.C;
  p.clip = clip.data();
  p.tris = c.scene.tris.data();
  p.num_tris = static_cast<std::int64_t>(c.scene.tris.size() / 3);
  p.tri_id = id.data();
  p.uv = uv.data();
  p.width = c.W;
  p.height = c.H;
  p.perspective = c.perspective;
  Result r{std::vector<float>(px * c.C), std::vector<float>(N * c.C), std::vector<float>(N * 4),
           std::vector<float>(2 * px)};
  interpolate_forward(p, r.out.data());
  interpolate_backward(p, grad_out.data(), InterpolateGrads<float>{r.grad_attr.data(), r.grad_clip.data(), r.grad_uv.data()});
  if (c.y_up)
    for (std::size_t i = 1; i < r.grad_clip.size(); i += 4) r.grad_clip[i] = -r.grad_clip[i];
  return r;
}

Result on_gpu(vulkan::Frame& frame, const Case& c, const std::vector<float>& attr, const std::vector<float>& grad_out) {
  const std::int64_t N = static_cast<std::int64_t>(c.scene.clip.size() / 4), px = std::int64_t(c.W) * c.H;
  vulkan::GpuRasterOptions options;
  options.y_up = c.y_up;
  frame.rasterize(c.scene.params(c.W, c.H), options);
  Result r{std::vector<float>(px * c.C), std::vector<float>(N * c.C), std::vector<float>(N * 4),
           std::vector<float>(2 * px)};
  frame.interpolate(attr.data(), c.C, c.perspective, r.out.data());
  frame.interpolate_backward(grad_out.data(), r.grad_attr.data(), r.grad_clip.data(), r.grad_uv.data());
  return r;
}

void require_close(const Result& gpu, const Result& cpu) {
  double largest_clip = 0.0;
  for (float g : cpu.grad_clip) largest_clip = std::max(largest_clip, double(std::abs(g)));
  INFO("largest |dL/dclip| " << largest_clip);
  CHECK(relative_error(gpu.out, cpu.out) <= 1e-6);
  CHECK(relative_error(gpu.grad_attr, cpu.grad_attr) <= 1e-5);
  CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
  CHECK(relative_error(gpu.grad_uv, cpu.grad_uv) <= 1e-5);
}

void check_case(const Case& c, unsigned seed) {
  const std::int64_t N = static_cast<std::int64_t>(c.scene.clip.size() / 4);
  const std::vector<float> attr = random_values(N * c.C, seed);
  const std::vector<float> grad_out = random_values(std::int64_t(c.W) * c.H * c.C, seed + 1);
  vulkan::Frame frame(shared_gpu());
  require_close(on_gpu(frame, c, attr, grad_out), on_cpu(c, attr, grad_out));
}

}  // namespace

TEST_CASE("GPU interpolate and its adjoint match the CPU kernels on soups crossing the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  for (std::int64_t C : {1, 3, 5}) {
    INFO(C << " channels");
    check_case({random_soup(200, 11 + unsigned(C)), 64, 48, C}, 3);
  }
}

TEST_CASE("GPU interpolate matches the CPU with linear weights and with nvdiffrast's rows", "[vulkan]") {
  if (!shared_gpu()) return;
  Case linear{random_soup(150, 21), 40, 40, 3};
  linear.perspective = false;
  check_case(linear, 5);
  Case y_up{random_soup(150, 22), 40, 40, 2};
  y_up.y_up = true;
  check_case(y_up, 6);
}

TEST_CASE("GPU interpolate matches the CPU on meshes in front of and through the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  for (double distance : {3.0, 0.6}) {
    INFO("distance " << distance);
    check_case({perspective(make_icosphere(3), 1.0, distance), 72, 64, 4}, 8);
  }
}

TEST_CASE("GPU interpolate's adjoint is the same bits every run and accumulates", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{perspective(make_torus(40, 20), 1.0, 2.2), 96, 96, 3};
  const std::int64_t N = static_cast<std::int64_t>(c.scene.clip.size() / 4);
  const std::vector<float> attr = random_values(N * 3, 1), grad_out = random_values(96 * 96 * 3, 2);
  vulkan::Frame frame(shared_gpu());
  const Result first = on_gpu(frame, c, attr, grad_out);
  for (int run = 0; run < 3; ++run) {
    const Result again = on_gpu(frame, c, attr, grad_out);
    REQUIRE(std::memcmp(again.grad_attr.data(), first.grad_attr.data(), first.grad_attr.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_clip.data(), first.grad_clip.data(), first.grad_clip.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_uv.data(), first.grad_uv.data(), first.grad_uv.size() * 4) == 0);
  }
  // += into what the arrays held.
  std::vector<float> grad_attr(N * 3, 1.0f);
  frame.interpolate_backward(grad_out.data(), grad_attr.data(), nullptr, nullptr);
  for (std::size_t i = 0; i < grad_attr.size(); ++i) REQUIRE(grad_attr[i] == 1.0f + first.grad_attr[i]);
}

TEST_CASE("GPU interpolate reports its passes' times", "[vulkan]") {
  if (!shared_gpu() || shared_gpu()->info().timestamp_period_ns <= 0.0) return;
  const Scene s = random_soup(50, 3);
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(s.params(32, 32));
  const std::vector<float> attr = random_values(s.clip.size() / 4 * 2, 1), grad = random_values(32 * 32 * 2, 2);
  CHECK(frame.interpolate(attr.data(), 2).pass_ms.size() == 1);
  CHECK(frame.interpolate_backward(grad.data(), nullptr, nullptr, nullptr).pass_ms.size() == 3);
}

TEST_CASE("GPU interpolate refuses to run before rasterize and its adjoint before interpolate", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::Frame frame(shared_gpu());
  const float attr[3] = {0, 0, 0};
  REQUIRE_THROWS_AS(frame.interpolate(attr, 1), ValueError);
  const Scene s = random_soup(3, 1);
  frame.rasterize(s.params(8, 8));
  std::vector<float> grad(64);
  REQUIRE_THROWS_WITH(frame.interpolate_backward(grad.data(), nullptr, nullptr, nullptr),
                      Catch::Contains("no interpolate"));
}
