// The GPU's interpolate and its adjoint (raster/vulkan/frame.h) against the
// CPU kernels (raster/barycentric_interpolate.h) on the CPU's G-buffer:
// values and attribute derivatives within 1e-6 and gradients (attributes,
// rast's u and v, rast_db) within 1e-5 relative to the largest, on random
// soups crossing the near plane, slivers, meshes, 1 to 5 channels, with and
// without attribute derivatives and in nvdiffrast's row order; the chain
// interpolate adjoint -> G-buffer adjoint on the device against the CPU's;
// the same bits run after run; accumulation (+=).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/barycentric_interpolate.h"
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
  std::vector<std::int32_t> diff = {};  // channels with derivatives (needs rast_db)
  bool y_up = false;
  std::int64_t vertices() const { return static_cast<std::int64_t>(scene.clip.size() / 4); }
  std::int64_t pixels() const { return std::int64_t(W) * H; }
  std::int64_t K() const { return static_cast<std::int64_t>(diff.size()); }
};

struct Inputs {
  std::vector<float> attr, grad_out, grad_da;
};

Inputs random_inputs(const Case& c, unsigned seed) {
  return {random_values(c.vertices() * c.C, seed), random_values(c.pixels() * c.C, seed + 1),
          random_values(c.pixels() * 2 * c.K(), seed + 2)};
}

struct Result {
  std::vector<float> out, da, grad_attr, grad_rast, grad_db;
};

Result empty_result(const Case& c) {
  const std::int64_t px = c.pixels();
  return {std::vector<float>(px * c.C), std::vector<float>(px * 2 * c.K()), std::vector<float>(c.vertices() * c.C),
          std::vector<float>(4 * px), std::vector<float>(c.K() > 0 ? 4 * px : 0)};
}

BarycentricInterpolateParams<float> cpu_params(const Case& c, const CpuGBuffer& gb, const Inputs& in) {
  BarycentricInterpolateParams<float> p;
  p.attr = in.attr.data();
  p.num_vertices = c.vertices();
  p.channels = c.C;
  p.tris = c.scene.tris.data();
  p.num_tris = static_cast<std::int64_t>(c.scene.tris.size() / 3);
  p.rast = gb.rast.data();
  p.pixels = c.pixels();
  p.tri_id = gb.id.data();
  if (c.K() > 0) {
    p.rast_db = gb.db.data();
    p.diff = c.diff.data();
    p.num_diff = c.K();
  }
  return p;
}

// The CPU kernels on the CPU's G-buffer.
Result on_cpu(const Case& c, const Inputs& in) {
  const CpuGBuffer gb = cpu_gbuffer(c.scene, c.W, c.H, c.y_up, c.K() > 0);
  const BarycentricInterpolateParams<float> p = cpu_params(c, gb, in);
  Result r = empty_result(c);
  barycentric_interpolate_forward(p, r.out.data(), c.K() > 0 ? r.da.data() : nullptr);
  barycentric_interpolate_backward(p, in.grad_out.data(), c.K() > 0 ? in.grad_da.data() : nullptr,
                                   {r.grad_attr.data(), r.grad_rast.data(), c.K() > 0 ? r.grad_db.data() : nullptr});
  return r;
}

vulkan::GpuRasterOptions options_of(const Case& c) {
  vulkan::GpuRasterOptions o;
  o.y_up = c.y_up;
  o.derivatives = c.K() > 0;
  return o;
}

Result on_gpu(vulkan::Frame& frame, const Case& c, const Inputs& in) {
  frame.rasterize(c.scene.params(c.W, c.H), options_of(c));
  Result r = empty_result(c);
  frame.interpolate(in.attr.data(), c.C, r.out.data(), c.diff.data(), c.K(), c.K() > 0 ? r.da.data() : nullptr);
  frame.interpolate_backward(in.grad_out.data(), c.K() > 0 ? in.grad_da.data() : nullptr, r.grad_attr.data(),
                             r.grad_rast.data(), c.K() > 0 ? r.grad_db.data() : nullptr);
  return r;
}

void require_close(const Result& gpu, const Result& cpu) {
  CHECK(relative_error(gpu.out, cpu.out) <= 1e-6);
  CHECK(relative_error(gpu.da, cpu.da) <= 1e-6);
  CHECK(relative_error(gpu.grad_attr, cpu.grad_attr) <= 1e-5);
  CHECK(relative_error(gpu.grad_rast, cpu.grad_rast) <= 1e-5);
  CHECK(relative_error(gpu.grad_db, cpu.grad_db) <= 1e-5);
}

void check_case(const Case& c, unsigned seed) {
  const Inputs in = random_inputs(c, seed);
  vulkan::Frame frame(shared_gpu());
  const Result cpu = on_cpu(c, in);
  REQUIRE(std::any_of(cpu.grad_attr.begin(), cpu.grad_attr.end(), [](float x) { return x != 0.0f; }));
  require_close(on_gpu(frame, c, in), cpu);
}

// The chain on the CPU: the interpolate adjoint's G-buffer gradient (added
// to extra, a gradient of rast from elsewhere: u, v, z/w) through the
// G-buffer adjoint to dL/dclip.
std::vector<float> chain_on_cpu(const Case& c, const Inputs& in, const std::vector<float>& extra) {
  const CpuGBuffer gb = cpu_gbuffer(c.scene, c.W, c.H, c.y_up, c.K() > 0);
  std::vector<float> grad_rast = extra, grad_db(c.K() > 0 ? 4 * c.pixels() : 0), grad_clip(4 * c.vertices());
  barycentric_interpolate_backward(cpu_params(c, gb, in), in.grad_out.data(),
                                   c.K() > 0 ? in.grad_da.data() : nullptr,
                                   {nullptr, grad_rast.data(), c.K() > 0 ? grad_db.data() : nullptr});
  barycentric_gbuffer_backward(gbuffer_params(c.scene, c.W, c.H, c.y_up), gb.rast.data(), grad_rast.data(),
                               c.K() > 0 ? grad_db.data() : nullptr, grad_clip.data());
  return grad_clip;
}

// The same chain on the device: the G-buffer gradient never leaves it.
std::vector<float> chain_on_gpu(vulkan::Frame& frame, const Case& c, const Inputs& in,
                                const std::vector<float>& extra) {
  frame.rasterize(c.scene.params(c.W, c.H), options_of(c));
  frame.interpolate(in.attr.data(), c.C, nullptr, c.diff.data(), c.K());
  frame.interpolate_backward(in.grad_out.data(), c.K() > 0 ? in.grad_da.data() : nullptr);
  std::vector<float> grad_clip(4 * c.vertices());
  frame.rasterize_backward(extra.data(), nullptr, grad_clip.data());
  return grad_clip;
}

}  // namespace

TEST_CASE("GPU interpolate and its adjoint match the CPU kernels on soups crossing the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  for (std::int64_t C : {1, 3, 5}) {
    INFO(C << " channels");
    check_case({random_soup(200, 11 + unsigned(C)), 64, 48, C}, 3);
  }
}

TEST_CASE("GPU interpolate matches the CPU with attribute derivatives, slivers and nvdiffrast's rows", "[vulkan]") {
  if (!shared_gpu()) return;
  check_case({random_soup(150, 21), 40, 40, 3, {0, 2}}, 5);
  check_case({random_soup(150, 22), 40, 40, 2, {1, 1, 0}, true}, 6);
  check_case({slivers(150, 23), 48, 48, 2, {1}}, 7);
  check_case({pixel_centre_grid(33, 8), 33, 33, 4, {3, 0}, true}, 8);
}

TEST_CASE("GPU interpolate matches the CPU on meshes in front of and through the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  for (double distance : {3.0, 0.6}) {
    INFO("distance " << distance);
    check_case({perspective(make_icosphere(3), 1.0, distance), 72, 64, 4, {0, 1}}, 8);
  }
}

TEST_CASE("GPU interpolate's adjoint chained into the G-buffer adjoint on the device matches the CPU's chain",
          "[vulkan]") {
  if (!shared_gpu()) return;
  const std::vector<Case> cases = {{random_soup(200, 41), 64, 48, 3},
                                   {random_soup(200, 42), 48, 64, 2, {0, 1}, true},
                                   {perspective(make_torus(40, 20), 1.0, 0.6), 80, 72, 3, {2}}};
  for (const Case& c : cases) {
    INFO(c.W << "x" << c.H << ", " << c.K() << " derivatives, y_up " << c.y_up);
    const Inputs in = random_inputs(c, 9);
    const std::vector<float> extra = random_values(4 * c.pixels(), 10);
    vulkan::Frame frame(shared_gpu());
    const std::vector<float> cpu = chain_on_cpu(c, in, extra);
    const double err = relative_error(chain_on_gpu(frame, c, in, extra), cpu);
    INFO("relative error " << err);
    CHECK(err <= 1e-5);
  }
}

TEST_CASE("GPU interpolate's adjoint is the same bits every run and accumulates", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{perspective(make_torus(40, 20), 1.0, 2.2), 96, 96, 3, {0}};
  const Inputs in = random_inputs(c, 1);
  vulkan::Frame frame(shared_gpu());
  const Result first = on_gpu(frame, c, in);
  for (int run = 0; run < 3; ++run) {
    const Result again = on_gpu(frame, c, in);
    REQUIRE(std::memcmp(again.grad_attr.data(), first.grad_attr.data(), first.grad_attr.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_rast.data(), first.grad_rast.data(), first.grad_rast.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_db.data(), first.grad_db.data(), first.grad_db.size() * 4) == 0);
  }
  // += into what the arrays held.
  std::vector<float> grad_attr(c.vertices() * 3, 1.0f), grad_rast(4 * c.pixels(), 2.0f);
  frame.interpolate_backward(in.grad_out.data(), in.grad_da.data(), grad_attr.data(), grad_rast.data());
  for (std::size_t i = 0; i < grad_attr.size(); ++i) REQUIRE(grad_attr[i] == 1.0f + first.grad_attr[i]);
  for (std::size_t i = 0; i < grad_rast.size(); ++i) REQUIRE(grad_rast[i] == 2.0f + first.grad_rast[i]);
}

TEST_CASE("GPU interpolate's adjoints left on the device add up in the G-buffer adjoint", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{random_soup(120, 51), 40, 40, 2};
  const Inputs in = random_inputs(c, 2);
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(c.scene.params(c.W, c.H));
  frame.interpolate(in.attr.data(), c.C);
  // Twice on the device, against the host sum of the G-buffer gradient of one, doubled.
  std::vector<float> grad_rast(4 * c.pixels());
  frame.interpolate_backward(in.grad_out.data(), nullptr, nullptr, grad_rast.data());
  frame.interpolate_backward(in.grad_out.data());
  frame.interpolate_backward(in.grad_out.data());
  std::vector<float> on_device(4 * c.vertices()), from_host(4 * c.vertices());
  frame.rasterize_backward(nullptr, nullptr, on_device.data());
  for (float& g : grad_rast) g += g;
  frame.rasterize_backward(grad_rast.data(), nullptr, from_host.data());
  REQUIRE(std::memcmp(on_device.data(), from_host.data(), on_device.size() * 4) == 0);
}

TEST_CASE("GPU interpolate reports its passes' times", "[vulkan]") {
  if (!shared_gpu() || shared_gpu()->info().timestamp_period_ns <= 0.0) return;
  const Scene s = random_soup(50, 3);
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(s.params(32, 32));
  const std::vector<float> attr = random_values(s.clip.size() / 4 * 2, 1), grad = random_values(32 * 32 * 2, 2);
  CHECK(frame.interpolate(attr.data(), 2).pass_ms.size() == 1);
  CHECK(frame.interpolate_backward(grad.data()).pass_ms.size() == 3);
}

TEST_CASE("GPU interpolate refuses bad calls with a message", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::Frame frame(shared_gpu());
  const std::vector<float> values(16);
  const float* attr = values.data();
  REQUIRE_THROWS_AS(frame.interpolate(attr, 1), ValueError);
  const Scene s = random_soup(3, 1);
  frame.rasterize(s.params(8, 8));
  std::vector<float> grad(64);
  REQUIRE_THROWS_WITH(frame.interpolate_backward(grad.data()), Catch::Contains("no interpolate"));
  const std::int32_t diff[1] = {0};
  REQUIRE_THROWS_WITH(frame.interpolate(attr, 1, nullptr, diff, 1), Catch::Contains("derivatives"));
  vulkan::GpuRasterOptions o;
  o.derivatives = true;
  frame.rasterize(s.params(8, 8), o);
  const std::int32_t beyond[1] = {1};
  REQUIRE_THROWS_AS(frame.interpolate(attr, 1, nullptr, beyond, 1), IndexError);
}

TEST_CASE("GPU interpolate of no channels and its adjoint take empty (null) buffers and add no gradient",
          "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::Frame frame(shared_gpu());
  const Scene s = random_soup(3, 1);
  frame.rasterize(s.params(8, 8));
  frame.interpolate(nullptr, 0);
  std::vector<float> grad_rast(4 * 64, 0.5f);
  // A caller's empty grad_out (no channels: torch and numpy give it no memory) is null.
  REQUIRE_NOTHROW(frame.interpolate_backward(nullptr, nullptr, nullptr, grad_rast.data()));
  CHECK(std::all_of(grad_rast.begin(), grad_rast.end(), [](float g) { return g == 0.5f; }));
}
