// The GPU's antialias and its adjoint (raster/vulkan/frame.h) against the CPU
// kernels (raster/antialias.h, float) on the same G-buffer (ids and z/w) and topology: the
// output within 1e-6 and the gradients (image, clip) within 1e-5 relative to
// the largest, on random soups crossing the near plane, meshes in front of
// and through the near plane, edges through pixel centres at 45 degrees, 1 and
// 3 channels and nvdiffrast's row order (on lavapipe all are bit-identical);
// the same bits run after run; accumulation (+=); the topology kept across
// calls and rebuilt when the triangles change.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/antialias.h"
#include "raster/procedural.h"
#include "raster/vulkan/frame.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

struct Case {
  Scene scene;
  int W, H, C;
  bool y_up = false;
};

struct Result {
  std::vector<float> out, grad_image, grad_clip;
  std::size_t blended = 0;  // CPU only: the pairs blended
};

std::int64_t vertices(const Case& c) { return static_cast<std::int64_t>(c.scene.clip.size() / 4); }
std::int64_t values(const Case& c) { return std::int64_t(c.W) * c.H * c.C; }

// The CPU kernels on the CPU's G-buffer (with y_up: of the clip with y negated).
Result on_cpu(const Case& c, const std::vector<float>& image, const std::vector<float>& grad_out) {
  const std::int64_t N = vertices(c), px = std::int64_t(c.W) * c.H;
  Scene flipped = c.scene;
  if (c.y_up)
    for (std::size_t i = 1; i < flipped.clip.size(); i += 4) flipped.clip[i] = -flipped.clip[i];
  // The G-buffer's coverage and z/w as the depth (as the ops pass them).
  const CpuGBuffer gb = cpu_gbuffer(c.scene, c.W, c.H, c.y_up);
  std::vector<float> depth(px);
  for (std::int64_t q = 0; q < px; ++q) depth[q] = gb.rast[4 * q + 2];
  const std::int64_t M = static_cast<std::int64_t>(c.scene.tris.size() / 3);
  const EdgeTopology topology = build_edge_topology(c.scene.tris.data(), M);
  AntialiasParams<float> p;
  p.image = image.data();
  p.channels = c.C;
  p.width = c.W;
  p.height = c.H;
  p.tri_id = gb.id.data();
  p.depth = depth.data();
  p.clip = flipped.clip.data();
  p.num_vertices = N;
  p.tris = c.scene.tris.data();
  p.num_tris = M;
  p.topology = &topology;
  Result r{std::vector<float>(values(c)), std::vector<float>(values(c)), std::vector<float>(N * 4)};
  std::vector<AntialiasPair> pairs;
  antialias_forward(p, r.out.data(), &pairs);
  antialias_backward(p, pairs, grad_out.data(), AntialiasGrads<float>{r.grad_image.data(), r.grad_clip.data()});
  if (c.y_up)
    for (std::size_t i = 1; i < r.grad_clip.size(); i += 4) r.grad_clip[i] = -r.grad_clip[i];
  r.blended = pairs.size();
  return r;
}

Result on_gpu(vulkan::Frame& frame, const Case& c, const std::vector<float>& image, const std::vector<float>& grad_out) {
  vulkan::GpuRasterOptions options;
  options.y_up = c.y_up;
  frame.rasterize(c.scene.params(c.W, c.H), options);
  Result r{std::vector<float>(values(c)), std::vector<float>(values(c)), std::vector<float>(vertices(c) * 4)};
  frame.antialias(image.data(), c.C, r.out.data());
  frame.antialias_backward(grad_out.data(), r.grad_image.data(), r.grad_clip.data());
  return r;
}

bool any_nonzero(const std::vector<float>& v) {
  return std::any_of(v.begin(), v.end(), [](float x) { return x != 0.0f; });
}

void require_close(const Result& gpu, const Result& cpu) {
  INFO(cpu.blended << " pairs blended on the CPU");
  REQUIRE(cpu.blended > 0);
  REQUIRE(any_nonzero(cpu.grad_clip));
  CHECK(relative_error(gpu.out, cpu.out) <= 1e-6);
  CHECK(relative_error(gpu.grad_image, cpu.grad_image) <= 1e-5);
  CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
}

void check_case(vulkan::Frame& frame, const Case& c, unsigned seed) {
  const std::vector<float> image = random_values(values(c), seed), grad_out = random_values(values(c), seed + 1);
  require_close(on_gpu(frame, c, image, grad_out), on_cpu(c, image, grad_out));
}

void check_case(const Case& c, unsigned seed) {
  vulkan::Frame frame(shared_gpu());
  check_case(frame, c, seed);
}

}  // namespace

TEST_CASE("GPU antialias and its adjoint match the CPU kernels on soups crossing the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  for (int C : {1, 3}) {
    INFO(C << " channels");
    check_case({random_soup(200, 31 + unsigned(C)), 64, 48, C}, 3);
  }
}

TEST_CASE("GPU antialias matches the CPU with nvdiffrast's rows", "[vulkan]") {
  if (!shared_gpu()) return;
  Case y_up{random_soup(150, 41), 40, 40, 3};
  y_up.y_up = true;
  check_case(y_up, 6);
}

TEST_CASE("GPU antialias matches the CPU on meshes in front of and through the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  SECTION("icosphere") { check_case({perspective(make_icosphere(3), 1.0, 3.0), 72, 64, 3}, 8); }
  // At distance 1.1 the ring's near side is behind the camera.
  for (double distance : {2.2, 1.1}) {
    INFO("torus at distance " << distance << ", y_up");
    Case torus{perspective(make_torus(40, 20), 1.0, distance), 96, 80, 1};
    torus.y_up = true;
    check_case(torus, 9);
  }
}

// Half of each quad of a grid whose vertices lie on pixel centres: the kept
// triangles' diagonals are silhouettes at exactly 45 degrees (the axis
// ownership tie, |dx| == |dy|) through pixel centres (t = 0 and 1/2 exactly).
Scene halved_grid(int W, int n) {
  Scene s = pixel_centre_grid(W, n);
  std::vector<std::int32_t> kept;
  for (std::size_t t = 0; t < s.tris.size(); t += 6) kept.insert(kept.end(), s.tris.begin() + t, s.tris.begin() + t + 3);
  s.tris = kept;
  return s;
}

TEST_CASE("GPU antialias matches the CPU on edges through pixel centres at 45 degrees", "[vulkan]") {
  if (!shared_gpu()) return;
  check_case({halved_grid(33, 4), 33, 33, 3}, 14);
  Case y_up{halved_grid(41, 5), 41, 41, 1};
  y_up.y_up = true;
  check_case(y_up, 15);
}

TEST_CASE("GPU antialias keeps the topology while the triangles stay and rebuilds it when they change", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::Frame frame(shared_gpu());
  const Scene sphere = perspective(make_icosphere(2), 1.0, 3.0);
  Scene moved = sphere;  // same triangles, other positions
  for (std::size_t i = 0; i < moved.clip.size(); i += 4) moved.clip[i] += 0.1f * moved.clip[i + 3];
  const Scene torus = perspective(make_torus(24, 12), 1.0, 2.2);
  const Scene* scenes[] = {&sphere, &moved, &torus, &sphere};
  for (const Scene* s : scenes) check_case(frame, {*s, 64, 64, 3}, 12);
}

TEST_CASE("GPU antialias and its adjoint are the same bits every run and accumulate", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{perspective(make_torus(40, 20), 1.0, 2.2), 96, 96, 3};
  const std::vector<float> image = random_values(values(c), 1), grad_out = random_values(values(c), 2);
  vulkan::Frame frame(shared_gpu());
  const Result first = on_gpu(frame, c, image, grad_out);
  REQUIRE(any_nonzero(first.grad_clip));
  for (int run = 0; run < 3; ++run) {
    vulkan::Frame other(shared_gpu());
    const Result again = on_gpu(run == 0 ? other : frame, c, image, grad_out);
    REQUIRE(std::memcmp(again.out.data(), first.out.data(), first.out.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_image.data(), first.grad_image.data(), first.grad_image.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_clip.data(), first.grad_clip.data(), first.grad_clip.size() * 4) == 0);
  }
  // += into what the arrays held.
  std::vector<float> grad_image(values(c), 1.0f), grad_clip(vertices(c) * 4, 1.0f);
  frame.antialias_backward(grad_out.data(), grad_image.data(), grad_clip.data());
  for (std::size_t i = 0; i < grad_image.size(); ++i) REQUIRE(grad_image[i] == 1.0f + first.grad_image[i]);
  for (std::size_t i = 0; i < grad_clip.size(); ++i) REQUIRE(grad_clip[i] == 1.0f + first.grad_clip[i]);
}

TEST_CASE("GPU antialias reports its passes' times", "[vulkan]") {
  if (!shared_gpu() || shared_gpu()->info().timestamp_period_ns <= 0.0) return;
  const Scene s = random_soup(50, 3);
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(s.params(32, 32));
  const std::vector<float> image = random_values(32 * 32 * 2, 1), grad = random_values(32 * 32 * 2, 2);
  CHECK(frame.antialias(image.data(), 2).pass_ms.size() == 2);
  CHECK(frame.antialias_backward(grad.data(), nullptr, nullptr).pass_ms.size() == 3);
}

TEST_CASE("GPU antialias refuses to run before rasterize and its adjoint before antialias", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::Frame frame(shared_gpu());
  const float image[3] = {0, 0, 0};
  REQUIRE_THROWS_AS(frame.antialias(image, 3), ValueError);
  const Scene s = random_soup(3, 1);
  frame.rasterize(s.params(8, 8));
  std::vector<float> grad(64 * 3), img(64 * 3);
  REQUIRE_THROWS_WITH(frame.antialias_backward(grad.data(), nullptr, nullptr), Catch::Contains("no antialias"));
  REQUIRE_THROWS_WITH(frame.antialias(img.data(), 0), Catch::Contains("channels"));
  frame.antialias(img.data(), 3);
  frame.rasterize(s.params(8, 8));  // a new G-buffer: the old antialias is gone
  REQUIRE_THROWS_WITH(frame.antialias_backward(grad.data(), nullptr, nullptr), Catch::Contains("no antialias"));
}

TEST_CASE("GPU antialias of the interpolated image left on the device equals antialias of it uploaded", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = perspective(make_torus(30, 15), 1.0, 2.2);
  const std::int64_t N = static_cast<std::int64_t>(s.clip.size() / 4);
  const std::vector<float> attr = random_values(N * 3, 4);
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(s.params(48, 40));
  std::vector<float> image(48 * 40 * 3), from_host(image.size()), on_device(image.size());
  frame.interpolate(attr.data(), 3, image.data());
  frame.antialias(image.data(), 3, from_host.data());
  frame.antialias(nullptr, 3, on_device.data());
  REQUIRE(std::memcmp(from_host.data(), on_device.data(), image.size() * sizeof(float)) == 0);
  REQUIRE_THROWS_WITH(frame.antialias(nullptr, 2), Catch::Contains("3 channels"));
}

namespace {

// antialias (with `topology`, or the frame's own when null) and its adjoint on the frame's current G-buffer.
Result antialias_on(vulkan::Frame& frame, const Case& c, const std::vector<float>& image,
                    const std::vector<float>& grad_out, const EdgeTopology* topology) {
  Result r{std::vector<float>(values(c)), std::vector<float>(values(c)), std::vector<float>(vertices(c) * 4)};
  frame.antialias(image.data(), c.C, r.out.data(), topology);
  frame.antialias_backward(grad_out.data(), r.grad_image.data(), r.grad_clip.data());
  return r;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// The upload-every-time path: a new frame, which holds no topology.
Result on_new_frame(const Case& c, const std::vector<float>& image, const std::vector<float>& grad_out,
                    const EdgeTopology* topology) {
  vulkan::Frame fresh(shared_gpu());
  fresh.rasterize(c.scene.params(c.W, c.H));
  return antialias_on(fresh, c, image, grad_out, topology);
}

void require_same_as_new_frame_and_cpu(const Result& r, const Case& c, const std::vector<float>& image,
                                       const std::vector<float>& grad_out, const EdgeTopology* topology) {
  const Result fresh = on_new_frame(c, image, grad_out, topology);
  REQUIRE(same_bits(r.out, fresh.out));
  REQUIRE(same_bits(r.grad_image, fresh.grad_image));
  REQUIRE(same_bits(r.grad_clip, fresh.grad_clip));
  const Result cpu = on_cpu(c, image, grad_out);
  REQUIRE(same_bits(r.out, cpu.out));  // the CPU's pairs and blends, bit for bit
  require_close(r, cpu);
}

}  // namespace

TEST_CASE("GPU antialias uploads a caller's topology once while it is the same and again for another one",
          "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{perspective(make_icosphere(2), 1.0, 3.0), 64, 56, 3};
  const std::int64_t M = static_cast<std::int64_t>(c.scene.tris.size() / 3);
  const std::vector<float> image = random_values(values(c), 21), grad_out = random_values(values(c), 22);
  const EdgeTopology first = build_edge_topology(c.scene.tris.data(), M);
  const EdgeTopology second = build_edge_topology(c.scene.tris.data(), M);  // the same content, another serial
  const EdgeTopology copy = first;                                          // the same serial
  REQUIRE(first.serial() != second.serial());
  REQUIRE(copy.serial() == first.serial());
  vulkan::Frame frame(shared_gpu());
  frame.rasterize(c.scene.params(c.W, c.H));
  const std::int64_t bytes = 3 * M * 4;
  struct Step {
    const EdgeTopology* topology;
    std::int64_t uploads;  // so far, after the step
  };
  // Each antialias_on runs the forward once (the adjoint uploads nothing).
  const Step steps[] = {{&first, 1}, {&first, 1}, {&copy, 1}, {&second, 2}, {&second, 2}, {&copy, 3}, {&first, 3}};
  for (const Step& step : steps) {
    const Result r = antialias_on(frame, c, image, grad_out, step.topology);
    CHECK(frame.topology_uploads().uploads == step.uploads);
    CHECK(frame.topology_uploads().bytes == step.uploads * bytes);
    require_same_as_new_frame_and_cpu(r, c, image, grad_out, step.topology);
  }
  // A new G-buffer of the same triangles keeps the device's copy.
  frame.rasterize(c.scene.params(c.W, c.H));
  require_same_as_new_frame_and_cpu(antialias_on(frame, c, image, grad_out, &first), c, image, grad_out, &first);
  CHECK(frame.topology_uploads().uploads == 3);
}

TEST_CASE("GPU antialias's own topology and a caller's replace each other on the device", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case sphere{perspective(make_icosphere(2), 1.0, 3.0), 64, 56, 3};
  const Case torus{perspective(make_torus(24, 12), 1.0, 2.2), 64, 56, 3};
  const std::vector<float> image = random_values(values(sphere), 23), grad_out = random_values(values(sphere), 24);
  const EdgeTopology sphere_topology =
      build_edge_topology(sphere.scene.tris.data(), static_cast<std::int64_t>(sphere.scene.tris.size() / 3));
  vulkan::Frame frame(shared_gpu());
  struct Step {
    const Case* c;
    const EdgeTopology* topology;  // null: the frame's own
    std::int64_t uploads;          // so far, after the step
  };
  const Step steps[] = {{&sphere, nullptr, 1},          {&sphere, nullptr, 1},         {&sphere, &sphere_topology, 2},
                        {&sphere, &sphere_topology, 2}, {&sphere, nullptr, 3},         {&sphere, &sphere_topology, 4},
                        {&torus, nullptr, 5},           {&sphere, &sphere_topology, 6}, {&sphere, nullptr, 7},
                        {&sphere, nullptr, 7}};
  for (const Step& step : steps) {
    INFO("step " << (&step - steps));
    frame.rasterize(step.c->scene.params(step.c->W, step.c->H));
    const Result r = antialias_on(frame, *step.c, image, grad_out, step.topology);
    CHECK(frame.topology_uploads().uploads == step.uploads);
    require_same_as_new_frame_and_cpu(r, *step.c, image, grad_out, step.topology);
  }
}

TEST_CASE("GPU antialias keeps a caller's topology across a loaded G-buffer", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{perspective(make_icosphere(2), 1.0, 3.0), 48, 40, 2};
  const std::int64_t M = static_cast<std::int64_t>(c.scene.tris.size() / 3);
  const EdgeTopology topology = build_edge_topology(c.scene.tris.data(), M);
  const std::vector<float> image = random_values(values(c), 25), grad_out = random_values(values(c), 26);
  const CpuGBuffer gb = cpu_gbuffer(c.scene, c.W, c.H, false);
  std::vector<float> depth(static_cast<std::size_t>(c.W) * c.H);
  for (std::size_t q = 0; q < depth.size(); ++q) depth[q] = gb.rast[4 * q + 2];
  vulkan::Frame frame(shared_gpu());
  for (int call = 0; call < 3; ++call) {
    frame.load_gbuffer(c.scene.params(c.W, c.H), {}, gb.id.data(), nullptr, 2, depth.data(), nullptr);
    const Result r = antialias_on(frame, c, image, grad_out, &topology);
    CHECK(frame.topology_uploads().uploads == 1);
    require_same_as_new_frame_and_cpu(r, c, image, grad_out, &topology);
  }
}
