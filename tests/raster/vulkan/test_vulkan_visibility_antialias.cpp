// The GPU's visibility antialias and its adjoint (raster/vulkan/frame.h,
// Frame::antialias with visibility) against the CPU kernels
// (raster/visibility_antialias.h, float) on the same G-buffer (ids and z/w)
// and topology: the output within 1e-6 and the gradients (image, clip) within
// 1e-5 relative to the largest (on lavapipe the same bits), on two triangles
// cutting through each other, random interpenetrating triangles, two
// interpenetrating spheres (welded from unshared vertices too), soups crossing
// the near plane and nvdiffrast's row order; equal to the GPU's antialias
// where nothing interpenetrates; the same bits run after run.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <vector>

#include "raster/antialias.h"
#include "raster/blended_pairs.h"
#include "raster/procedural.h"
#include "raster/visibility_antialias.h"
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
  bool weld = false;  // the topology welds vertices with equal clip rows
};

struct Result {
  std::vector<float> out, grad_image, grad_clip;
  VisibilityAntialiasStats stats;  // CPU only
  bool exact = false;              // CPU only: the same bits expected (lavapipe)
};

std::int64_t vertices(const Case& c) { return static_cast<std::int64_t>(c.scene.clip.size() / 4); }
std::int64_t triangles(const Case& c) { return static_cast<std::int64_t>(c.scene.tris.size() / 3); }
std::int64_t values(const Case& c) { return std::int64_t(c.W) * c.H * c.C; }

EdgeTopology topology_of(const Case& c) {
  return c.weld ? build_edge_topology<float>(c.scene.tris.data(), triangles(c), vertices(c), c.scene.clip.data(), 4)
                : build_edge_topology(c.scene.tris.data(), triangles(c));
}

// The CPU kernels on the CPU's G-buffer (with y_up: of the clip with y negated).
Result on_cpu(const Case& c, bool visibility, const std::vector<float>& image, const std::vector<float>& grad_out) {
  const std::int64_t N = vertices(c), px = std::int64_t(c.W) * c.H;
  Scene flipped = c.scene;
  if (c.y_up)
    for (std::size_t i = 1; i < flipped.clip.size(); i += 4) flipped.clip[i] = -flipped.clip[i];
  const CpuGBuffer gb = cpu_gbuffer(c.scene, c.W, c.H, c.y_up);
  std::vector<float> depth(px);
  for (std::int64_t q = 0; q < px; ++q) depth[q] = gb.rast[4 * q + 2];
  const EdgeTopology topology = topology_of(c);
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
  p.num_tris = triangles(c);
  p.topology = &topology;
  Result r{std::vector<float>(values(c)), std::vector<float>(values(c)), std::vector<float>(N * 4), {}};
  BlendedPairs pairs;
  AntialiasStats silhouette;
  blend_boundaries_forward(visibility, p, r.out.data(), &pairs, {&silhouette, &r.stats});
  if (!visibility) r.stats.edge_pairs = silhouette.blended_pairs;
  blend_boundaries_backward(p, pairs, grad_out.data(), AntialiasGrads<float>{r.grad_image.data(), r.grad_clip.data()});
  if (c.y_up)
    for (std::size_t i = 1; i < r.grad_clip.size(); i += 4) r.grad_clip[i] = -r.grad_clip[i];
  return r;
}

Result on_gpu(vulkan::Frame& frame, const Case& c, bool visibility, const std::vector<float>& image,
              const std::vector<float>& grad_out) {
  vulkan::GpuRasterOptions options;
  options.y_up = c.y_up;
  frame.rasterize(c.scene.params(c.W, c.H), options);
  Result r{std::vector<float>(values(c)), std::vector<float>(values(c)), std::vector<float>(vertices(c) * 4), {}};
  const EdgeTopology topology = topology_of(c);
  frame.antialias(image.data(), c.C, r.out.data(), c.weld ? &topology : nullptr, visibility);
  frame.antialias_backward(grad_out.data(), r.grad_image.data(), r.grad_clip.data());
  return r;
}

bool any_nonzero(const std::vector<float>& v) {
  return std::any_of(v.begin(), v.end(), [](float x) { return x != 0.0f; });
}

bool lavapipe() { return shared_gpu() && shared_gpu()->info().is_cpu; }

void require_close(const Result& gpu, const Result& cpu) {
  INFO(cpu.stats.edge_pairs << " edge pairs and " << cpu.stats.intersection_pairs << " crossings blended on the CPU");
  REQUIRE(cpu.stats.edge_pairs + cpu.stats.intersection_pairs > 0);
  REQUIRE(any_nonzero(cpu.grad_clip));
  CHECK(relative_error(gpu.out, cpu.out) <= 1e-6);
  CHECK(relative_error(gpu.grad_image, cpu.grad_image) <= 1e-5);
  CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
  if (lavapipe()) {
    // The pairs and blends are the CPU's bits; the clip gradient's fixed-point
    // sums are exact where the CPU's double sums leave rounding residue (a
    // gradient that cancels to 1e-16 on the CPU is 0 here).
    CHECK(std::memcmp(gpu.out.data(), cpu.out.data(), cpu.out.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(gpu.grad_image.data(), cpu.grad_image.data(), cpu.grad_image.size() * sizeof(float)) == 0);
    CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-7);
  }
}

// Checks the case and returns the CPU's pair counts.
VisibilityAntialiasStats check_case(vulkan::Frame& frame, const Case& c, unsigned seed) {
  const std::vector<float> image = random_values(values(c), seed), grad_out = random_values(values(c), seed + 1);
  const Result cpu = on_cpu(c, true, image, grad_out);
  require_close(on_gpu(frame, c, true, image, grad_out), cpu);
  return cpu.stats;
}

VisibilityAntialiasStats check_case(const Case& c, unsigned seed) {
  vulkan::Frame frame(shared_gpu());
  return check_case(frame, c, seed);
}

}  // namespace

TEST_CASE("GPU visibility antialias matches the CPU at two triangles cutting through each other", "[vulkan]") {
  if (!shared_gpu()) return;
  for (bool along_x : {true, false}) {
    INFO((along_x ? "along x" : "along y"));
    for (int C : {1, 3}) {
      const VisibilityAntialiasStats stats = check_case({crossing_pair(along_x), 24, 20, C}, 5 + unsigned(C));
      CHECK(stats.intersection_pairs >= 5);
    }
    Case y_up{crossing_pair(along_x), 40, 33, 2};
    y_up.y_up = true;
    CHECK(check_case(y_up, 9).intersection_pairs >= 5);
  }
}

TEST_CASE("GPU visibility antialias matches the CPU on random interpenetrating triangles", "[vulkan]") {
  if (!shared_gpu()) return;
  vulkan::Frame frame(shared_gpu());  // one frame: the topology rebuilt for each scene
  std::int64_t crossings = 0;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    INFO("seed " << seed);
    crossings += check_case(frame, {interpenetrating(2 + int(seed % 4) * 3, seed), 48, 40, 3}, seed).intersection_pairs;
  }
  CHECK(crossings > 40);
}

TEST_CASE("GPU visibility antialias matches the CPU on interpenetrating spheres, welded or not", "[vulkan]") {
  if (!shared_gpu()) return;
  CHECK(check_case({two_spheres(false), 80, 72, 3}, 21).intersection_pairs > 10);
  Case welded{two_spheres(true), 80, 72, 3};
  welded.weld = true;
  CHECK(check_case(welded, 22).intersection_pairs > 10);
  welded.y_up = true;
  check_case(welded, 23);
}

TEST_CASE("GPU visibility antialias matches the CPU on soups crossing the near plane", "[vulkan]") {
  if (!shared_gpu()) return;
  check_case({random_soup(200, 35), 64, 48, 3}, 4);
  Case y_up{random_soup(150, 41), 40, 40, 1};
  y_up.y_up = true;
  check_case(y_up, 6);
}

TEST_CASE("GPU visibility antialias equals the GPU antialias where nothing interpenetrates", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case cases[] = {{perspective(make_icosphere(3), 1.0, 3.0), 72, 64, 3},
                        {perspective(make_torus(40, 20), 1.0, 2.2), 96, 80, 1}};
  for (const Case& c : cases) {
    const std::vector<float> image = random_values(values(c), 3), grad_out = random_values(values(c), 4);
    vulkan::Frame frame(shared_gpu());
    const Result plain = on_gpu(frame, c, false, image, grad_out);
    const Result visibility = on_gpu(frame, c, true, image, grad_out);
    REQUIRE(on_cpu(c, true, image, grad_out).stats.intersection_pairs == 0);
    REQUIRE(any_nonzero(plain.grad_clip));
    CHECK(std::memcmp(plain.out.data(), visibility.out.data(), plain.out.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(plain.grad_image.data(), visibility.grad_image.data(), plain.grad_image.size() * 4) == 0);
    CHECK(relative_error(visibility.grad_clip, plain.grad_clip) <= 1e-6);
  }
}

TEST_CASE("GPU visibility antialias and its adjoint are the same bits every run and accumulate", "[vulkan]") {
  if (!shared_gpu()) return;
  const Case c{two_spheres(false), 96, 96, 3};
  const std::vector<float> image = random_values(values(c), 1), grad_out = random_values(values(c), 2);
  vulkan::Frame frame(shared_gpu());
  const Result first = on_gpu(frame, c, true, image, grad_out);
  REQUIRE(any_nonzero(first.grad_clip));
  for (int run = 0; run < 3; ++run) {
    vulkan::Frame other(shared_gpu());
    const Result again = on_gpu(run == 0 ? other : frame, c, true, image, grad_out);
    REQUIRE(std::memcmp(again.out.data(), first.out.data(), first.out.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_image.data(), first.grad_image.data(), first.grad_image.size() * 4) == 0);
    REQUIRE(std::memcmp(again.grad_clip.data(), first.grad_clip.data(), first.grad_clip.size() * 4) == 0);
  }
  std::vector<float> grad_image(values(c), 1.0f), grad_clip(vertices(c) * 4, 1.0f);
  frame.antialias_backward(grad_out.data(), grad_image.data(), grad_clip.data());
  for (std::size_t i = 0; i < grad_image.size(); ++i) REQUIRE(grad_image[i] == 1.0f + first.grad_image[i]);
  for (std::size_t i = 0; i < grad_clip.size(); ++i) REQUIRE(grad_clip[i] == 1.0f + first.grad_clip[i]);
}
