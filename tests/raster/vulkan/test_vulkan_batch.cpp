// The batch ops (ops/render/batch.h) on a Vulkan backend: rasterize_batch
// (instanced) and rasterize_ranges (range mode) make each image's G-buffer on
// the device, downloaded as the CPU's bit for bit and kept there (one handle
// per image), and interpolate_batch, antialias_batch and the G-buffer's
// adjoint run image by image on the backend: values within 1e-6 and
// gradients within 1e-5 of the CPU's (relative to the largest), the same run
// to run. With no more images than the backend's frames the ops read the
// device's copies (no upload; range mode's antialias too, reading the whole
// triangle list, which its topology indexes, with the copy's ids offset by
// the range's first row); with more they upload the host's, with the same
// results. The batch ops defer their calls (raster::DeferredCalls): the same
// bits as calls waited for one by one.
#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include "ops/ops.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::testing;

namespace {

// The batch: instanced (one triangle list, clip [B, N, 4], attributes
// [B, N, C]) or range mode (the images' soups in one list, clip and
// attributes shared, each image its own range of triangles).
struct Batch {
  Tensor clip, tris, ranges, attr;
};

constexpr int kImages = 3;

Batch instanced_batch() {
  std::vector<float> clip;
  std::vector<std::int32_t> tris;
  for (int b = 0; b < kImages; ++b) {
    const Scene s = random_soup(60, 21 + b);
    clip.insert(clip.end(), s.clip.begin(), s.clip.end());
    tris = s.tris;  // the same for every image
  }
  const std::int64_t n = static_cast<std::int64_t>(tris.size()), m = n / 3;
  return {Tensor::from_vector<float>(clip, {kImages, n, 4}), Tensor::from_vector<std::int32_t>(tris, {m, 3}), Tensor(),
          Tensor::from_vector<float>(random_values(static_cast<std::size_t>(kImages * n * 3), 5), {kImages, n, 3})};
}

Batch range_batch() {
  const int counts[kImages] = {40, 25, 55};
  std::vector<float> clip;
  std::vector<std::int32_t> tris, ranges;
  for (int b = 0; b < kImages; ++b) {
    const Scene s = random_soup(counts[b], 31 + b);
    const auto base = static_cast<std::int32_t>(clip.size() / 4);
    ranges.insert(ranges.end(), {static_cast<std::int32_t>(tris.size() / 3), counts[b]});
    clip.insert(clip.end(), s.clip.begin(), s.clip.end());
    for (std::int32_t v : s.tris) tris.push_back(base + v);
  }
  const std::int64_t n = static_cast<std::int64_t>(clip.size() / 4), m = static_cast<std::int64_t>(tris.size() / 3);
  return {Tensor::from_vector<float>(clip, {n, 4}), Tensor::from_vector<std::int32_t>(tris, {m, 3}),
          Tensor::from_vector<std::int32_t>(ranges, {kImages, 2}),
          Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 2), 6), {n, 2})};
}

struct Run {
  std::vector<std::int32_t> tri_id;
  std::vector<float> uv, depth, db, shaded, image, grad_clip, grad_attr;
};

std::vector<float> values_of(const Tensor& t) {
  if (!t.defined()) return {};
  return std::vector<float>(t.data<float>(), t.data<float>() + t.numel());
}

Tensor weights(const Tensor& like, unsigned seed) {
  return Tensor::from_vector<float>(random_values(static_cast<std::size_t>(like.numel()), seed), like.shape());
}

// rasterize (with derivatives) -> interpolate -> antialias (or visibility_antialias) -> loss -> backward.
Run run_batch(const Batch& in, int W, int H, const std::shared_ptr<const raster::RasterBackend>& backend,
              bool visibility = false) {
  Tensor clip = in.clip.copy().set_requires_grad();
  Tensor attr = in.attr.copy().set_requires_grad();
  RasterizeOptions ro{W, H};
  ro.derivatives = true;
  ro.backend = backend;
  const GBuffer gb = in.ranges.defined() ? rasterize_ranges(clip, in.tris, in.ranges, ro)
                                         : rasterize_batch(clip, in.tris, ro);
  const Tensor shaded = interpolate_batch(attr, gb, in.tris);
  AntialiasOptions ao;
  ao.visibility = visibility;
  ao.pos_gradient_boost = visibility ? 1.5 : 1.0;
  const Tensor image = antialias_batch(shaded, gb, clip, in.tris, ao);
  // Every output in the loss: the G-buffer's gradient from interpolate and from outside it.
  const Tensor loss = sum(image * weights(image, 11)) + sum(gb.uv * weights(gb.uv, 12)) +
                      sum(gb.depth * weights(gb.depth, 13)) + sum(gb.db * weights(gb.db, 14));
  backward(loss);
  const std::int32_t* ids = gb.tri_id.data<std::int32_t>();
  return {std::vector<std::int32_t>(ids, ids + gb.tri_id.numel()),
          values_of(gb.uv),
          values_of(gb.depth),
          values_of(gb.db),
          values_of(shaded),
          values_of(image),
          values_of(clip.grad()),
          values_of(attr.grad())};
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

// The backend's run against the CPU's, and against itself run again.
void expect_cpu_results(const Batch& in, int W, int H, const std::shared_ptr<const raster::RasterBackend>& backend,
                        bool visibility = false) {
  const Run cpu = run_batch(in, W, H, nullptr, visibility);
  const Run gpu = run_batch(in, W, H, backend, visibility);
  REQUIRE(gpu.tri_id == cpu.tri_id);
  REQUIRE(same_bits(gpu.uv, cpu.uv));
  REQUIRE(same_bits(gpu.depth, cpu.depth));
  REQUIRE(same_bits(gpu.db, cpu.db));
  CHECK(relative_error(gpu.shaded, cpu.shaded) <= 1e-6);
  CHECK(relative_error(gpu.image, cpu.image) <= 1e-6);
  CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
  CHECK(relative_error(gpu.grad_attr, cpu.grad_attr) <= 1e-5);
  const Run again = run_batch(in, W, H, backend, visibility);
  CHECK(same_bits(again.image, gpu.image));
  CHECK(same_bits(again.grad_clip, gpu.grad_clip));
  CHECK(same_bits(again.grad_attr, gpu.grad_attr));
}

}  // namespace

TEST_CASE("an instanced batch on a Vulkan backend gives the CPU's G-buffers, values and gradients", "[vulkan][batch]") {
  if (!shared_gpu()) return;
  const Batch in = instanced_batch();
  const auto backend = vulkan::raster_backend(shared_gpu(), 4);
  expect_cpu_results(in, 40, 32, backend);
  // Per run: three G-buffers made and kept, each read by five calls
  // (interpolate and antialias forward and adjoint, the rasterize adjoint).
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.gbuffers == 2 * kImages);
  CHECK(stats.resident_calls == 2 * 5 * kImages);
  CHECK(stats.uploads == 0);
}

TEST_CASE("an instanced batch through visibility_antialias on a Vulkan backend gives the CPU's results",
          "[vulkan][batch]") {
  if (!shared_gpu()) return;
  // Each image's triangles cut through each other.
  std::vector<float> clip;
  std::vector<std::int32_t> tris;
  for (int b = 0; b < kImages; ++b) {
    const Scene s = interpenetrating(10, 41 + b);
    clip.insert(clip.end(), s.clip.begin(), s.clip.end());
    tris = s.tris;
  }
  const std::int64_t n = static_cast<std::int64_t>(tris.size()), m = n / 3;
  const Batch in{Tensor::from_vector<float>(clip, {kImages, n, 4}), Tensor::from_vector<std::int32_t>(tris, {m, 3}),
                 Tensor(),
                 Tensor::from_vector<float>(random_values(static_cast<std::size_t>(kImages * n * 3), 8),
                                            {kImages, n, 3})};
  const auto backend = vulkan::raster_backend(shared_gpu(), 4);
  expect_cpu_results(in, 40, 32, backend, true);
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.gbuffers == 2 * kImages);
  CHECK(stats.resident_calls == 2 * 5 * kImages);
  CHECK(stats.uploads == 0);
}

TEST_CASE("a range mode batch on a Vulkan backend gives the CPU's G-buffers, values and gradients", "[vulkan][batch]") {
  if (!shared_gpu()) return;
  const Batch in = range_batch();
  const auto backend = vulkan::raster_backend(shared_gpu(), 4);
  expect_cpu_results(in, 40, 32, backend);
  // Every call reads the device's copies: interpolate's, the rasterize
  // adjoint's, and antialias's (forward and adjoint), which read the whole
  // list its topology indexes, the copy's ids offset by the range's first row.
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.gbuffers == 2 * kImages);
  CHECK(stats.resident_calls == 2 * 5 * kImages);
  CHECK(stats.uploads == 0);
}

TEST_CASE("range mode antialias walks past its range into the whole mesh as the CPU does, reading the kept copies",
          "[vulkan][batch]") {
  if (!shared_gpu()) return;
  // Parts of two connected spheres: a walk from a range's triangle crosses
  // its interior edges into triangles outside the range (the CPU's
  // antialias walks the whole list's surface), so a sub-list's topology
  // would blend where the CPU does not.
  const Scene s = two_spheres(false);
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  const auto third = static_cast<std::int32_t>(m / 3);
  const std::vector<std::int32_t> ranges = {third, third, 5, 2 * third, 2 * third, 0};
  const Batch in{Tensor::from_vector<float>(s.clip, {n, 4}), Tensor::from_vector<std::int32_t>(s.tris, {m, 3}),
                 Tensor::from_vector<std::int32_t>(ranges, {kImages, 2}),
                 Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 2), 9), {n, 2})};
  for (bool visibility : {false, true}) {
    const auto backend = vulkan::raster_backend(shared_gpu(), 4);
    expect_cpu_results(in, 48, 40, backend, visibility);
    const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
    CHECK(stats.uploads == 0);
    CHECK(stats.resident_calls == 2 * 5 * kImages);
  }
}

TEST_CASE("a batch with more images than the backend's frames uploads them and gives the CPU's results",
          "[vulkan][batch]") {
  if (!shared_gpu()) return;
  SECTION("instanced") {
    const auto backend = vulkan::raster_backend(shared_gpu(), 2);
    expect_cpu_results(instanced_batch(), 40, 32, backend);
    // The first image's calls upload it; the last two images stay kept (uploads have a frame of their own).
    const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
    CHECK(stats.uploads > 0);
    CHECK(stats.resident_calls == 2 * stats.uploads);
  }
  SECTION("range mode") {
    const auto backend = vulkan::raster_backend(shared_gpu(), 1);
    expect_cpu_results(range_batch(), 40, 32, backend);
    CHECK(vulkan::residency_stats(*backend).uploads > 0);
    CHECK(vulkan::residency_stats(*backend).resident_calls > 0);  // the last image's kept copy
  }
}

TEST_CASE("a batch G-buffer written in place is uploaded by the batch ops with the same results", "[vulkan][batch]") {
  if (!shared_gpu()) return;
  const Batch in = instanced_batch();
  const auto backend = vulkan::raster_backend(shared_gpu(), 4);
  RasterizeOptions ro{40, 32};
  ro.backend = backend;
  GBuffer gb = rasterize_batch(in.clip, in.tris, ro);
  const Tensor before = interpolate_batch(in.attr, gb, in.tris);
  // The same values written back: the handle is stale, the host's tensors are uploaded.
  const std::vector<float> uv = values_of(gb.uv);
  std::memcpy(gb.uv.data<float>(), uv.data(), uv.size() * sizeof(float));
  const std::int64_t uploads = vulkan::residency_stats(*backend).uploads;
  const Tensor after = interpolate_batch(in.attr, gb, in.tris);
  CHECK(vulkan::residency_stats(*backend).uploads == uploads + kImages);
  CHECK(same_bits(values_of(after), values_of(before)));
}

namespace {

bool same_run(const Run& a, const Run& b) {
  return a.tri_id == b.tri_id && same_bits(a.uv, b.uv) && same_bits(a.depth, b.depth) && same_bits(a.db, b.db) &&
         same_bits(a.shaded, b.shaded) && same_bits(a.image, b.image) && same_bits(a.grad_clip, b.grad_clip) &&
         same_bits(a.grad_attr, b.grad_attr);
}

}  // namespace

TEST_CASE("a batch's calls on a Vulkan backend are deferred and give the bits of calls waited for one by one",
          "[vulkan][batch]") {
  if (!shared_gpu()) return;
  struct Case {
    const char* name;
    Batch in;
    bool visibility;
  };
  const Case cases[] = {{"instanced", instanced_batch(), false},
                        {"instanced, visibility", instanced_batch(), true},
                        {"range mode", range_batch(), false}};
  for (const Case& c : cases)
    for (int frames : {4, 2, 1}) {  // 2 and 1: frames reused within a batch, so calls wait for earlier ones
      INFO(c.name << ", " << frames << " frames");
      const auto deferring = vulkan::raster_backend(shared_gpu(), frames, true);
      const auto waiting = vulkan::raster_backend(shared_gpu(), frames, false);
      const Run deferred = run_batch(c.in, 40, 32, deferring, c.visibility);
      const Run waited = run_batch(c.in, 40, 32, waiting, c.visibility);
      CHECK(same_run(deferred, waited));
      CHECK(vulkan::residency_stats(*waiting).deferred_calls == 0);
      if (frames == 4)  // each image's six calls (rasterize, interpolate, antialias, their adjoints)
        CHECK(vulkan::residency_stats(*deferring).deferred_calls == 6 * kImages);
      else
        CHECK(vulkan::residency_stats(*deferring).deferred_calls > 0);
    }
}

TEST_CASE("a call that fails among deferred calls leaves the backend giving the CPU's results", "[vulkan][batch]") {
  if (!shared_gpu()) return;
  const auto backend = vulkan::raster_backend(shared_gpu(), 4);
  const Scene good = random_soup(30, 5);
  Scene bad = good;
  bad.clip[5] = std::numeric_limits<float>::quiet_NaN();
  std::vector<std::int32_t> ids(24 * 16);
  std::vector<float> uv(2 * 24 * 16), depth(24 * 16);
  {
    raster::DeferredCalls deferred(backend.get());
    CHECK(backend->rasterize_gbuffer(good.params(24, 16), ids.data(), uv.data(), depth.data(), nullptr, nullptr));
    CHECK_THROWS_AS(
        backend->rasterize_gbuffer(bad.params(24, 16), ids.data(), uv.data(), depth.data(), nullptr, nullptr),
        ValueError);
  }  // unwound without finish(): the device finishes, nothing is written
  expect_cpu_results(instanced_batch(), 40, 32, backend);
}

namespace {

// An instanced batch on `first` and a range mode batch on `second`, run at
// once on two threads `rounds` times: each gives the bits it gives alone.
void check_batches_on_two_threads(const std::shared_ptr<const raster::RasterBackend>& first,
                                  const std::shared_ptr<const raster::RasterBackend>& second, int rounds) {
  const Batch a = instanced_batch(), b = range_batch();
  const Run alone_a = run_batch(a, 40, 32, first), alone_b = run_batch(b, 40, 32, second);
  for (int round = 0; round < rounds; ++round) {
    Run together_a, together_b;
    std::thread other([&] { together_b = run_batch(b, 40, 32, second); });
    together_a = run_batch(a, 40, 32, first);
    other.join();
    CHECK(same_run(together_a, alone_a));
    CHECK(same_run(together_b, alone_b));
  }
}

}  // namespace

TEST_CASE("two threads running batches on one deferring backend get the single-threaded bits", "[vulkan][batch]") {
  if (!shared_gpu()) return;
  const auto backend = vulkan::raster_backend(shared_gpu(), 4);
  check_batches_on_two_threads(backend, backend, 1);
}

TEST_CASE("two threads running batches on two backends of one device defer at once and get the single-threaded bits",
          "[vulkan][batch]") {
  if (!shared_gpu()) return;
  const auto first = vulkan::raster_backend(shared_gpu(), 4), second = vulkan::raster_backend(shared_gpu(), 4);
  check_batches_on_two_threads(first, second, 3);
  CHECK(vulkan::residency_stats(*first).deferred_calls == 4 * 6 * kImages);
  CHECK(vulkan::residency_stats(*second).deferred_calls == 4 * 6 * kImages);
}
