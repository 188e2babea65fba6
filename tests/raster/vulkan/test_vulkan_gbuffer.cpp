// The GPU's G-buffer (vulkan::Frame::rasterize) and its adjoint
// (Frame::rasterize_backward) against the CPU kernels
// (raster/barycentric_gbuffer.h on raster::rasterize_forward's coverage): ids
// identical, rast (u, v, z/w, id) and rast_db bit for bit, dL/dclip within
// 1e-5 relative to the largest (through u, v, z/w and rast_db), on soups
// crossing the near plane, slivers, edges through pixel centres, meshes and
// nvdiffrast's row order; the same bits run after run; accumulation (+=);
// the device's G-buffer gradient consumed by one adjoint.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/procedural.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

template <class T>
std::int64_t differing(const std::vector<T>& a, const std::vector<T>& b) {
  std::int64_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(T)) != 0;
  return n;
}

vulkan::GpuRasterOptions options_for(bool y_up, bool derivatives) {
  vulkan::GpuRasterOptions o;
  o.y_up = y_up;
  o.derivatives = derivatives;
  return o;
}

// The forward: everything bit for bit.
void check_forward(const Scene& s, int W, int H, bool y_up) {
  INFO(W << "x" << H << ", y_up " << y_up);
  const CpuGBuffer cpu = cpu_gbuffer(s, W, H, y_up, true);
  std::int64_t covered = 0;
  for (std::int32_t t : cpu.id) covered += t > 0;
  INFO("pixels covered " << covered);
  REQUIRE(covered > 0);
  CpuGBuffer gpu{std::vector<std::int32_t>(cpu.id.size(), -7), std::vector<float>(cpu.rast.size(), -7.f),
                 std::vector<float>(cpu.db.size(), -7.f)};
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(s.params(W, H), options_for(y_up, true), gpu.id.data(), gpu.rast.data(), gpu.db.data());
  CHECK(differing(gpu.id, cpu.id) == 0);
  CHECK(differing(gpu.rast, cpu.rast) == 0);
  CHECK(differing(gpu.db, cpu.db) == 0);
  // Without derivatives the same rast.
  std::vector<float> rast(cpu.rast.size(), -7.f);
  frame.rasterize(s.params(W, H), options_for(y_up, false), nullptr, rast.data());
  CHECK(differing(rast, cpu.rast) == 0);
}

struct Grads {
  std::vector<float> rast, db;
};

std::vector<float> adjoint_on_cpu(const Scene& s, int W, int H, bool y_up, const Grads& g, bool with_db) {
  const CpuGBuffer gb = cpu_gbuffer(s, W, H, y_up);
  std::vector<float> grad(s.clip.size(), 0.0f);
  barycentric_gbuffer_backward(gbuffer_params(s, W, H, y_up), gb.rast.data(), g.rast.data(),
                               with_db ? g.db.data() : nullptr, grad.data());
  return grad;
}

std::vector<float> adjoint_on_gpu(vulkan::Frame& frame, const Scene& s, int W, int H, bool y_up, const Grads& g,
                                  bool with_db) {
  frame.rasterize(s.params(W, H), options_for(y_up, with_db));
  std::vector<float> grad(s.clip.size(), 0.0f);
  frame.rasterize_backward(g.rast.data(), with_db ? g.db.data() : nullptr, grad.data());
  return grad;
}

double largest(const std::vector<float>& v) {
  double m = 0.0;
  for (float x : v) m = std::max(m, double(std::abs(x)));
  return m;
}

void check_adjoint(const Scene& s, int W, int H, bool y_up, unsigned seed) {
  const std::int64_t px = std::int64_t(W) * H;
  const Grads g{random_values(4 * px, seed), random_values(4 * px, seed + 1)};
  vulkan::Frame frame(shared_gpu());
  for (bool with_db : {false, true}) {
    INFO("grad_db " << with_db << ", y_up " << y_up);
    const std::vector<float> cpu = adjoint_on_cpu(s, W, H, y_up, g, with_db);
    REQUIRE(largest(cpu) > 0.0);
    const double err = relative_error(adjoint_on_gpu(frame, s, W, H, y_up, g, with_db), cpu);
    INFO("relative error " << err);
    CHECK(err <= 1e-5);
  }
}

}  // namespace

TEST_CASE("the GPU's G-buffer of soups crossing the near plane is the CPU kernels' bit for bit", "[vulkan]") {
  if (!shared_gpu()) return;
  check_forward(random_soup(300, 1), 64, 48, false);
  check_forward(random_soup(300, 2), 37, 91, true);
}

TEST_CASE("the GPU's G-buffer of slivers, pixel-centre edges and meshes is the CPU kernels' bit for bit", "[vulkan]") {
  if (!shared_gpu()) return;
  check_forward(slivers(200, 3), 96, 64, false);
  check_forward(slivers(200, 4), 64, 96, true);
  check_forward(pixel_centre_grid(33, 8), 33, 33, false);
  check_forward(perspective(make_icosphere(3), 1.0, 3.0), 72, 64, true);
  check_forward(perspective(make_torus(40, 20), 1.0, 0.6), 80, 72, false);
}

TEST_CASE("the GPU's G-buffer adjoint matches the CPU on soups crossing the near plane and slivers", "[vulkan]") {
  if (!shared_gpu()) return;
  check_adjoint(random_soup(200, 31), 64, 48, false, 1);
  check_adjoint(random_soup(200, 32), 48, 64, true, 2);
  check_adjoint(slivers(150, 33), 64, 64, false, 3);
  check_adjoint(pixel_centre_grid(33, 8), 33, 33, true, 4);
}

TEST_CASE("the GPU's G-buffer adjoint matches the CPU on meshes in front of and through the near plane",
          "[vulkan]") {
  if (!shared_gpu()) return;
  check_adjoint(perspective(make_icosphere(3), 1.0, 3.0), 80, 72, false, 5);
  check_adjoint(perspective(make_torus(40, 20), 1.0, 0.6), 80, 72, false, 6);
}

TEST_CASE("the GPU's G-buffer adjoint is the same bits every run and accumulates", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = perspective(make_icosphere(4), 1.0, 2.0);
  const Grads g{random_values(4 * 96 * 96, 5), random_values(4 * 96 * 96, 6)};
  vulkan::Frame frame(shared_gpu());
  const std::vector<float> first = adjoint_on_gpu(frame, s, 96, 96, false, g, true);
  for (int run = 0; run < 3; ++run)
    REQUIRE(std::memcmp(adjoint_on_gpu(frame, s, 96, 96, false, g, true).data(), first.data(), first.size() * 4) == 0);
  std::vector<float> grad(s.clip.size(), 2.0f);
  frame.rasterize_backward(g.rast.data(), g.db.data(), grad.data());
  for (std::size_t i = 0; i < grad.size(); ++i) REQUIRE(grad[i] == 2.0f + first[i]);
  // Nothing incoming (no host gradient, none left on the device): nothing added.
  frame.rasterize_backward(nullptr, nullptr, grad.data());
  for (std::size_t i = 0; i < grad.size(); ++i) REQUIRE(grad[i] == 2.0f + first[i]);
}

TEST_CASE("the GPU's G-buffer passes report their times", "[vulkan]") {
  if (!shared_gpu() || shared_gpu()->info().timestamp_period_ns <= 0.0) return;
  const Scene s = random_soup(50, 3);
  vulkan::Frame frame(shared_gpu());
  CHECK(frame.rasterize(s.params(32, 32)).pass_ms.size() == 6);
  const std::vector<float> grad = random_values(32 * 32 * 4, 2);
  std::vector<float> grad_clip(s.clip.size());
  CHECK(frame.rasterize_backward(grad.data(), nullptr, grad_clip.data()).pass_ms.size() == 3);
}

TEST_CASE("the GPU's G-buffer refuses db without derivatives and an adjoint before rasterize", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = random_soup(5, 1);
  vulkan::Frame frame(shared_gpu());
  std::vector<float> grad(8 * 8 * 4), grad_clip(s.clip.size());
  REQUIRE_THROWS_WITH(frame.rasterize_backward(grad.data(), nullptr, grad_clip.data()),
                      Catch::Contains("no G-buffer"));
  std::vector<float> db(8 * 8 * 4);
  REQUIRE_THROWS_WITH(frame.rasterize(s.params(8, 8), {}, nullptr, nullptr, db.data()),
                      Catch::Contains("derivatives"));
  frame.rasterize(s.params(8, 8));
  REQUIRE_THROWS_WITH(frame.rasterize_backward(grad.data(), db.data(), grad_clip.data()),
                      Catch::Contains("without derivatives"));
}

TEST_CASE("the GPU's frame uploads a mesh's triangle list once while it stays the same and again when it changes",
          "[vulkan]") {
  if (!shared_gpu()) return;
  Scene sphere = perspective(make_icosphere(3), 1.0, 3.0);
  const Scene torus = perspective(make_torus(40, 20), 1.0, 2.2);
  const std::int64_t sphere_bytes = static_cast<std::int64_t>(sphere.tris.size()) * 4;
  const int W = 72, H = 64;
  vulkan::Frame frame(shared_gpu());
  // Every step's G-buffer is the CPU kernels', bit for bit, whether the triangles went up or not.
  auto rasterize_and_check = [&](const Scene& s, std::int64_t uploads_after) {
    const CpuGBuffer cpu = cpu_gbuffer(s, W, H, false, true);
    CpuGBuffer gpu{std::vector<std::int32_t>(cpu.id.size(), -7), std::vector<float>(cpu.rast.size(), -7.f),
                   std::vector<float>(cpu.db.size(), -7.f)};
    frame.rasterize(s.params(W, H), options_for(false, true), gpu.id.data(), gpu.rast.data(), gpu.db.data());
    CHECK(differing(gpu.id, cpu.id) == 0);
    CHECK(differing(gpu.rast, cpu.rast) == 0);
    CHECK(differing(gpu.db, cpu.db) == 0);
    CHECK(frame.triangle_uploads().uploads == uploads_after);
  };
  rasterize_and_check(sphere, 1);
  rasterize_and_check(sphere, 1);  // the same triangles: kept
  CHECK(frame.triangle_uploads().bytes == sphere_bytes);
  for (std::size_t i = 0; i < sphere.clip.size(); i += 4) sphere.clip[i] += 0.05f;  // moved vertices, same triangles
  rasterize_and_check(sphere, 1);
  rasterize_and_check(torus, 2);
  rasterize_and_check(sphere, 3);
  std::swap(sphere.tris[0], sphere.tris[1]);  // the same array written in place: its winding flips
  rasterize_and_check(sphere, 4);
  // A G-buffer loaded from the host keeps the device's triangles too, and its adjoint reads them.
  const CpuGBuffer cpu = cpu_gbuffer(sphere, W, H, false, false);
  std::vector<float> depth(static_cast<std::size_t>(W) * H);
  for (std::size_t q = 0; q < depth.size(); ++q) depth[q] = cpu.rast[4 * q + 2];
  const std::vector<float> grad = random_values(4 * W * H, 7);
  std::vector<float> loaded(sphere.clip.size()), rasterized(sphere.clip.size());
  frame.load_gbuffer(sphere.params(W, H), {}, cpu.id.data(), cpu.rast.data(), 4, depth.data(), nullptr);
  CHECK(frame.triangle_uploads().uploads == 4);
  frame.rasterize_backward(grad.data(), nullptr, loaded.data());
  vulkan::Frame fresh(shared_gpu());
  fresh.rasterize(sphere.params(W, H));
  fresh.rasterize_backward(grad.data(), nullptr, rasterized.data());
  CHECK(differing(loaded, rasterized) == 0);
}
