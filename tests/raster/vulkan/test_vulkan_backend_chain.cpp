// The ops' G-buffer chain on a Vulkan backend (raster/vulkan/backend.h):
// rasterize -> interpolate (with attribute derivatives) -> antialias -> loss
// -> backward (antialias or visibility_antialias), with the G-buffer's backend running interpolate, antialias and
// the rasterize adjoint, against the same chain on the CPU. Issue 33's rule:
// values within 1e-6 and every gradient within 1e-5 of the CPU's (relative
// to the largest), bit-identical run to run. The G-buffer is made on the
// device, downloaded bit for bit as the CPU's, and kept there: the ops after
// it read the device's copy (no upload: ResidencyStats), and when the backend
// has let it go (more G-buffers alive than frames) or its host tensors were
// written since, they upload the host's, with the same results.
#include <catch2/catch.hpp>

#include <cstring>
#include <memory>
#include <thread>
#include <utility>
#include <vector>

#include "ops/ops.h"
#include "raster/procedural.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::testing;

namespace {

// How the chain is run: attribute derivatives (with a repeated channel) or a
// plain interpolate with a background; the antialias topology welded from
// the clip rows (the op's default) or by index; the position gradient boost;
// visibility_antialias instead of antialias.
struct Chain {
  int channels = 3;
  bool derivatives = true;
  bool index_topology = false;
  double boost = 1.0;
  bool visibility = false;
};

// Outputs and gradients of one run, as float vectors.
struct Run {
  std::vector<std::int32_t> tri_id;
  std::vector<float> uv, depth, db, image, d_dx, d_dy, grad_clip, grad_attr;
};

std::vector<float> values_of(const Tensor& t) {
  if (!t.defined()) return {};
  return std::vector<float>(t.data<float>(), t.data<float>() + t.numel());
}

Tensor weights(const Tensor& like, unsigned seed) {
  return Tensor::from_vector<float>(random_values(static_cast<std::size_t>(like.numel()), seed), like.shape());
}

Run run_chain(const Scene& s, int W, int H, const Chain& c,
              const std::shared_ptr<const raster::RasterBackend>& backend) {
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  Tensor clip = Tensor::from_vector<float>(s.clip, {n, 4}).set_requires_grad();
  const Tensor tris = Tensor::from_vector<std::int32_t>(s.tris, {m, 3});
  Tensor attr = Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * c.channels), 7), {n, c.channels})
                    .set_requires_grad();
  RasterizeOptions ro{W, H};
  ro.derivatives = c.derivatives;
  ro.backend = backend;
  const GBuffer gb = rasterize(clip, tris, ro);
  InterpolateOptions io;
  Tensor shaded, d_dx, d_dy;
  if (c.derivatives) {
    io.diff_attrs = {0, std::int32_t(c.channels - 1), 0};
    const InterpolatedWithDerivatives ip = interpolate_with_derivatives(attr, gb, tris, io);
    shaded = ip.values;
    d_dx = ip.d_dx;
    d_dy = ip.d_dy;
  } else {
    io.background = Tensor::full({c.channels}, 0.25);
    shaded = interpolate(attr, gb, tris, io);
  }
  AntialiasOptions ao;
  if (c.index_topology) ao.topology = antialias_topology(tris);
  ao.pos_gradient_boost = c.boost;
  ao.visibility = c.visibility;
  const Tensor image = antialias(shaded, gb, clip, tris, ao);
  // Every output in the loss with its own weights; uv also directly (a
  // G-buffer gradient from outside interpolate), depth too.
  Tensor loss = sum(image * weights(image, 11)) + sum(gb.uv * weights(gb.uv, 12)) +
                sum(gb.depth * weights(gb.depth, 13));
  if (c.derivatives) loss = loss + sum(d_dx * weights(d_dx, 14)) + sum(d_dy * weights(d_dy, 15));
  backward(loss);
  const std::int32_t* ids = gb.tri_id.data<std::int32_t>();
  return {std::vector<std::int32_t>(ids, ids + gb.tri_id.numel()),
          values_of(gb.uv),
          values_of(gb.depth),
          values_of(gb.db),
          values_of(image),
          values_of(d_dx),
          values_of(d_dy),
          values_of(clip.grad()),
          values_of(attr.grad())};
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

// The GPU chain against the CPU's, and against itself run again.
void check_chain(const Scene& s, int W, int H, const Chain& c) {
  const auto backend = vulkan::raster_backend(shared_gpu());
  const Run cpu = run_chain(s, W, H, c, nullptr);
  const Run gpu = run_chain(s, W, H, c, backend);
  // One G-buffer made on the device and read there by the interpolate and
  // antialias forwards and adjoints and the rasterize adjoint: no upload.
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.gbuffers == 1);
  CHECK(stats.uploads == 0);
  CHECK(stats.resident_calls == 5);
  // The adjoints read what their forwards left there (no second pair pass or interpolation).
  CHECK(stats.antialias_reused == 1);
  CHECK(stats.interpolate_reused == 1);
  const Run again = run_chain(s, W, H, c, backend);
  // The coverage and G-buffer as downloaded: the CPU's bit for bit.
  REQUIRE(gpu.tri_id == cpu.tri_id);
  REQUIRE(same_bits(gpu.uv, cpu.uv));
  REQUIRE(same_bits(gpu.depth, cpu.depth));
  REQUIRE(same_bits(gpu.db, cpu.db));
  CHECK(relative_error(gpu.image, cpu.image) <= 1e-6);
  CHECK(relative_error(gpu.d_dx, cpu.d_dx) <= 1e-6);
  CHECK(relative_error(gpu.d_dy, cpu.d_dy) <= 1e-6);
  CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
  CHECK(relative_error(gpu.grad_attr, cpu.grad_attr) <= 1e-5);
  // The largest differences, for docs/gpu.md.
  WARN("GPU vs CPU, max relative difference: image " << relative_error(gpu.image, cpu.image) << ", d/dx "
                                                   << relative_error(gpu.d_dx, cpu.d_dx) << ", d/dy "
                                                   << relative_error(gpu.d_dy, cpu.d_dy) << ", dL/dclip "
                                                   << relative_error(gpu.grad_clip, cpu.grad_clip) << ", dL/dattr "
                                                   << relative_error(gpu.grad_attr, cpu.grad_attr));
  CHECK(same_bits(again.image, gpu.image));
  CHECK(same_bits(again.d_dx, gpu.d_dx));
  CHECK(same_bits(again.grad_clip, gpu.grad_clip));
  CHECK(same_bits(again.grad_attr, gpu.grad_attr));
}

}  // namespace

TEST_CASE("the op chain on a Vulkan backend gives the CPU's values and gradients on random soups", "[vulkan]") {
  if (!shared_gpu()) return;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    INFO("seed " << seed);
    check_chain(random_soup(120, seed), 48, 40, {});
  }
  SECTION("one channel, no derivatives, a background") { check_chain(random_soup(100, 9), 40, 48, {1, false}); }
  SECTION("topology by index and a gradient boost") { check_chain(random_soup(100, 5), 40, 40, {3, true, true, 4.0}); }
}

TEST_CASE("the op chain on a Vulkan backend gives the CPU's values and gradients on hard cases", "[vulkan]") {
  if (!shared_gpu()) return;
  SECTION("slivers") { check_chain(slivers(60, 4), 64, 48, {}); }
  SECTION("edges through pixel centres") { check_chain(pixel_centre_grid(32, 6), 32, 32, {2}); }
  SECTION("a torus through the near plane") {
    check_chain(perspective(raster::make_torus(40, 20), 1.0, 1.0), 64, 56, {});
  }
  SECTION("an icosphere, welded topology") {
    check_chain(perspective(raster::make_icosphere(2), 1.0, 3.0), 48, 48, {3, false});
  }
  SECTION("a torus, topology by index, one channel") {
    check_chain(perspective(raster::make_torus(24, 12), 1.0, 2.2), 40, 40, {1, true, true});
  }
}

TEST_CASE("the op chain with visibility_antialias on a Vulkan backend gives the CPU's values and gradients",
          "[vulkan]") {
  if (!shared_gpu()) return;
  Chain visibility;
  visibility.visibility = true;
  // At z = 0 the G-buffer's depth is a signed zero (-0 where the CPU divides
  // +0 by a negative D): the bit-for-bit G-buffer check sees its sign.
  SECTION("two triangles cutting through each other at z = 0") { check_chain(crossing_pair(true), 24, 20, visibility); }
  SECTION("two triangles cutting through each other off z = 0") {
    Scene lifted = crossing_pair(true);
    for (std::size_t i = 2; i < lifted.clip.size(); i += 4) lifted.clip[i] += 0.05f * lifted.clip[i + 1];
    check_chain(lifted, 24, 20, visibility);
  }
  SECTION("random interpenetrating triangles") { check_chain(interpenetrating(8, 3), 48, 40, visibility); }
  SECTION("interpenetrating spheres, welded from unshared vertices") {
    check_chain(two_spheres(true), 64, 56, visibility);
  }
  SECTION("a closed mesh (as antialias), one channel, no derivatives") {
    Chain plain = visibility;
    plain.channels = 1;
    plain.derivatives = false;
    check_chain(perspective(raster::make_icosphere(2), 1.0, 3.0), 48, 48, plain);
  }
  SECTION("topology by index and a gradient boost") {
    Chain boosted = visibility;
    boosted.index_topology = true;
    boosted.boost = 2.5;
    check_chain(two_spheres(false), 56, 48, boosted);
  }
}

TEST_CASE("the op chain on a Vulkan backend leaves float64 on the CPU bit for bit", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = random_soup(40, 2);
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  Tensor grads[2];
  for (int run = 0; run < 2; ++run) {
    Tensor clip = cast(Tensor::from_vector<float>(s.clip, {n, 4}), DType::Float64).set_requires_grad();
    const Tensor tris = Tensor::from_vector<std::int32_t>(s.tris, {m, 3});
    const Tensor attr = Tensor::uniform({n, 2}, -1, 1, 3, DType::Float64);
    RasterizeOptions ro{32, 24};
    if (run == 1) ro.backend = vulkan::raster_backend(shared_gpu());
    const GBuffer gb = rasterize(clip, tris, ro);
    backward(sum(pow(antialias(interpolate(attr, gb, tris), gb, clip, tris), 2.0)));
    grads[run] = clip.grad();
  }
  REQUIRE(grads[0].numel() == grads[1].numel());
  CHECK(std::memcmp(grads[0].data<double>(), grads[1].data<double>(), grads[0].numel() * sizeof(double)) == 0);
}

namespace {

Run expect_same(const Run& gpu, const Run& cpu) {
  CHECK(gpu.tri_id == cpu.tri_id);
  CHECK(relative_error(gpu.image, cpu.image) <= 1e-6);
  CHECK(relative_error(gpu.d_dx, cpu.d_dx) <= 1e-6);
  CHECK(relative_error(gpu.grad_clip, cpu.grad_clip) <= 1e-5);
  CHECK(relative_error(gpu.grad_attr, cpu.grad_attr) <= 1e-5);
  return gpu;
}

void append(std::vector<float>& to, const std::vector<float>& from) { to.insert(to.end(), from.begin(), from.end()); }

// Two interpolates on one G-buffer (colours with their derivatives, normals
// without), shaded together, antialiased; loss and backward.
Run run_two_interpolates(const Scene& s, int W, int H, const std::shared_ptr<const raster::RasterBackend>& backend) {
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  Tensor clip = Tensor::from_vector<float>(s.clip, {n, 4}).set_requires_grad();
  const Tensor tris = Tensor::from_vector<std::int32_t>(s.tris, {m, 3});
  Tensor colours = Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 3), 21), {n, 3})
                       .set_requires_grad();
  Tensor normals = Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 3), 22), {n, 3})
                       .set_requires_grad();
  RasterizeOptions ro{W, H};
  ro.derivatives = true;
  ro.backend = backend;
  const GBuffer gb = rasterize(clip, tris, ro);
  const InterpolatedWithDerivatives c = interpolate_with_derivatives(colours, gb, tris);
  const Tensor lit = interpolate(normals, gb, tris);
  const Tensor image = antialias(c.values * lit, gb, clip, tris);
  backward(sum(image * weights(image, 23)) + sum(c.d_dx * weights(c.d_dx, 24)) + sum(lit * weights(lit, 25)));
  Run r;
  r.image = values_of(image);
  r.d_dx = values_of(c.d_dx);
  r.grad_clip = values_of(clip.grad());
  r.grad_attr = values_of(colours.grad());
  append(r.grad_attr, values_of(normals.grad()));
  return r;
}

// interpolate -> antialias -> loss -> backward; with `another`, a second
// antialias (of another image, without gradient) on the same G-buffer between
// the first and its adjoint: its pairs replace the first's on the device, so
// the first's adjoint recomputes them.
Run run_antialias(const Scene& s, int W, int H, const std::shared_ptr<const raster::RasterBackend>& backend,
                  bool another) {
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  Tensor clip = Tensor::from_vector<float>(s.clip, {n, 4}).set_requires_grad();
  const Tensor tris = Tensor::from_vector<std::int32_t>(s.tris, {m, 3});
  Tensor colours = Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 3), 27), {n, 3})
                       .set_requires_grad();
  RasterizeOptions ro{W, H};
  ro.backend = backend;
  const GBuffer gb = rasterize(clip, tris, ro);
  const Tensor c = interpolate(colours, gb, tris);
  const Tensor image = antialias(c, gb, clip, tris);
  if (another) {
    NoGradGuard no_grad;
    antialias(c * c, gb, clip, tris);
  }
  backward(sum(image * weights(image, 28)));
  Run r;
  r.image = values_of(image);
  r.grad_clip = values_of(clip.grad());
  r.grad_attr = values_of(colours.grad());
  return r;
}

// Every scene's G-buffer made first, then each one's interpolate, then each
// one's antialias, one loss: the G-buffers are read (and their adjoints run)
// interleaved, while all are alive.
Run run_interleaved(const std::vector<Scene>& scenes, int W, int H,
                    const std::shared_ptr<const raster::RasterBackend>& backend) {
  std::vector<Tensor> clips, tris, attrs, shaded;
  std::vector<GBuffer> gbs;
  RasterizeOptions ro{W, H};
  ro.derivatives = true;
  ro.backend = backend;
  for (const Scene& s : scenes) {
    const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
    clips.push_back(Tensor::from_vector<float>(s.clip, {n, 4}).set_requires_grad());
    tris.push_back(Tensor::from_vector<std::int32_t>(s.tris, {m, 3}));
    attrs.push_back(Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 2), 31), {n, 2})
                        .set_requires_grad());
    gbs.push_back(rasterize(clips.back(), tris.back(), ro));
  }
  for (std::size_t i = 0; i < scenes.size(); ++i)
    shaded.push_back(interpolate_with_derivatives(attrs[i], gbs[i], tris[i]).values);
  Run r;
  Tensor loss = Tensor::scalar(0.0);
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    const Tensor image = antialias(shaded[i], gbs[i], clips[i], tris[i]);
    loss = loss + sum(image * weights(image, 40 + unsigned(i))) + sum(gbs[i].uv * weights(gbs[i].uv, 50 + unsigned(i)));
    append(r.image, values_of(image));
    const std::int32_t* ids = std::as_const(gbs[i].tri_id).data<std::int32_t>();
    r.tri_id.insert(r.tri_id.end(), ids, ids + gbs[i].tri_id.numel());
  }
  backward(loss);
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    append(r.grad_clip, values_of(clips[i].grad()));
    append(r.grad_attr, values_of(attrs[i].grad()));
  }
  return r;
}

}  // namespace

TEST_CASE("two interpolates on one G-buffer read the device's copy and give the CPU's results", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = perspective(raster::make_torus(30, 16), 1.0, 1.6);
  const auto backend = vulkan::raster_backend(shared_gpu());
  const Run gpu = expect_same(run_two_interpolates(s, 48, 40, backend), run_two_interpolates(s, 48, 40, nullptr));
  // Two interpolates and their adjoints, the antialias and its adjoint, the rasterize adjoint.
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.uploads == 0);
  CHECK(stats.resident_calls == 7);
  // The later interpolate's adjoint (run first) reads its forward's attributes; the earlier one's interpolates again.
  CHECK(stats.interpolate_reused == 1);
  const Run again = run_two_interpolates(s, 48, 40, backend);
  CHECK(same_bits(again.grad_clip, gpu.grad_clip));
  CHECK(same_bits(again.grad_attr, gpu.grad_attr));
}

TEST_CASE("an antialias adjoint reads its forward's pairs while the device keeps them, else recomputes them, with the same bits",
          "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = perspective(raster::make_torus(30, 16), 1.0, 1.6);
  const Run cpu = run_antialias(s, 48, 40, nullptr, false);
  const auto backend = vulkan::raster_backend(shared_gpu());
  const Run kept = expect_same(run_antialias(s, 48, 40, backend, false), cpu);
  CHECK(vulkan::residency_stats(*backend).antialias_reused == 1);
  const Run recomputed = expect_same(run_antialias(s, 48, 40, backend, true), cpu);
  CHECK(vulkan::residency_stats(*backend).antialias_reused == 1);  // the pairs had gone
  CHECK(vulkan::residency_stats(*backend).uploads == 0);
  CHECK(same_bits(recomputed.grad_clip, kept.grad_clip));
  CHECK(same_bits(recomputed.grad_attr, kept.grad_attr));
}

TEST_CASE("G-buffers the backend has let go are uploaded again and give the CPU's results", "[vulkan]") {
  if (!shared_gpu()) return;
  const std::vector<Scene> scenes = {random_soup(80, 3), perspective(raster::make_icosphere(2), 1.0, 3.0),
                                     perspective(raster::make_torus(24, 12), 1.0, 2.2)};
  const Run cpu = run_interleaved(scenes, 40, 32, nullptr);
  SECTION("three G-buffers alive, two frames") {
    const auto backend = vulkan::raster_backend(shared_gpu(), 2);
    expect_same(run_interleaved(scenes, 40, 32, backend), cpu);
    const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
    CHECK(stats.frames == 2);
    // The first G-buffer's five calls upload it; the two kept stay kept (uploads use a frame of their own).
    CHECK(stats.uploads == 5);
    CHECK(stats.resident_calls == 2 * 5);
  }
  SECTION("three G-buffers alive, one frame") {
    const auto backend = vulkan::raster_backend(shared_gpu(), 1);
    expect_same(run_interleaved(scenes, 40, 32, backend), cpu);
    const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
    CHECK(stats.uploads == 2 * 5);
    CHECK(stats.resident_calls == 5);  // the last G-buffer: the others' uploads did not take its frame
  }
  SECTION("three G-buffers alive, four frames: none uploaded") {
    const auto backend = vulkan::raster_backend(shared_gpu());
    expect_same(run_interleaved(scenes, 40, 32, backend), cpu);
    const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
    CHECK(stats.frames == 3);
    CHECK(stats.uploads == 0);
  }
}

TEST_CASE("a G-buffer written on the host since rasterize is read from the host", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene s = random_soup(60, 4);
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  const Tensor clip = Tensor::from_vector<float>(s.clip, {n, 4});
  const Tensor tris = Tensor::from_vector<std::int32_t>(s.tris, {m, 3});
  const Tensor attr = Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 3), 5), {n, 3});
  const auto backend = vulkan::raster_backend(shared_gpu());
  RasterizeOptions ro{32, 32};
  ro.backend = backend;
  GBuffer gb = rasterize(clip, tris, ro);
  const std::vector<float> before = values_of(interpolate(attr, gb, tris));
  CHECK(vulkan::residency_stats(*backend).uploads == 0);
  // The CPU's interpolate and antialias of the G-buffer as it is now.
  auto on_cpu = [&](const GBuffer& g) {
    GBuffer host = g;
    host.backend = nullptr;
    host.resident = nullptr;
    const Tensor shaded = interpolate(attr, host, tris);
    return std::make_pair(values_of(shaded), values_of(antialias(shaded, host, clip, tris)));
  };
  SECTION("uv written in place") {
    float* uv = gb.uv.data<float>();
    const std::int32_t* ids = gb.tri_id.data<std::int32_t>();
    std::int64_t q = 0;
    while (ids[q] == 0) ++q;
    std::swap(uv[2 * q], uv[2 * q + 1]);  // still barycentrics, another point of the triangle
    const std::vector<float> after = values_of(interpolate(attr, gb, tris));
    CHECK(after != before);
    CHECK(relative_error(after, on_cpu(gb).first) <= 1e-6);
    CHECK(vulkan::residency_stats(*backend).uploads == 1);
  }
  SECTION("depth replaced by another tensor") {
    Tensor depth = gb.depth.copy();
    float* d = depth.data<float>();
    for (std::int64_t q = 0; q < depth.numel(); ++q) d[q] = -d[q];  // the other triangle in front at each pair
    gb.depth = depth;
    const Tensor shaded = interpolate(attr, gb, tris);
    CHECK(relative_error(values_of(antialias(shaded, gb, clip, tris)), on_cpu(gb).second) <= 1e-6);
    const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
    CHECK(stats.uploads == 2);  // interpolate (the depth is part of the G-buffer checked) and antialias
  }
}

TEST_CASE("two threads rendering on one backend at once get the CPU's results", "[vulkan]") {
  if (!shared_gpu()) return;
  const Scene scenes[2] = {random_soup(120, 6), perspective(raster::make_torus(40, 20), 1.0, 1.0)};
  const Run cpu[2] = {run_chain(scenes[0], 48, 40, {}, nullptr), run_chain(scenes[1], 48, 40, {}, nullptr)};
  const auto backend = vulkan::raster_backend(shared_gpu());
  constexpr int kRounds = 3;
  Run gpu[2][kRounds];
  std::string failed[2];
  std::thread threads[2];
  for (int t = 0; t < 2; ++t)
    threads[t] = std::thread([&, t] {
      try {
        for (int r = 0; r < kRounds; ++r) gpu[t][r] = run_chain(scenes[t], 48, 40, {}, backend);
      } catch (const std::exception& e) {
        failed[t] = e.what();
      }
    });
  for (std::thread& t : threads) t.join();
  for (int t = 0; t < 2; ++t) {
    INFO("thread " << t);
    REQUIRE(failed[t].empty());
    for (int r = 0; r < kRounds; ++r) {
      expect_same(gpu[t][r], cpu[t]);
      CHECK(same_bits(gpu[t][r].grad_clip, gpu[t][0].grad_clip));
    }
  }
  const vulkan::ResidencyStats stats = vulkan::residency_stats(*backend);
  CHECK(stats.gbuffers == 2 * kRounds);
  CHECK(stats.uploads == 0);  // at most two G-buffers alive, four frames
}

TEST_CASE("antialias without a topology uploads its welded topology once over calls on the same triangles",
          "[vulkan]") {
  if (!shared_gpu()) return;
  // The op keeps the topology it welds (ops/render/topology_cache.h): the same
  // object while the triangles are unwritten and the weld holds, so the
  // frame keeps its upload; written triangles give a new one, uploaded again.
  const Scene s = perspective(raster::make_icosphere(2), 1.0, 3.0);
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  Tensor tris = Tensor::from_vector<std::int32_t>(s.tris, {m, 3});
  const Tensor attr = Tensor::from_vector<float>(random_values(static_cast<std::size_t>(n * 3), 9), {n, 3});
  const auto backend = vulkan::raster_backend(shared_gpu(), 1);
  auto render = [&](float shift, const std::shared_ptr<const raster::RasterBackend>& on) {
    std::vector<float> rows = s.clip;
    for (std::int64_t v = 0; v < n; ++v) rows[4 * v] += shift * rows[4 * v + 3];  // x moved by `shift` in NDC
    Tensor clip = Tensor::from_vector<float>(rows, {n, 4}).set_requires_grad();
    RasterizeOptions ro{48, 40};
    ro.backend = on;
    const GBuffer gb = rasterize(clip, tris, ro);
    const Tensor image = antialias(interpolate(attr, gb, tris), gb, clip, tris);
    backward(sum(image * weights(image, 3)));
    return std::make_pair(values_of(image), values_of(clip.grad()));
  };
  const float shifts[] = {0.0f, 0.0f, 0.0f, 0.05f, -0.05f};
  for (float shift : shifts) {
    const auto gpu = render(shift, backend), cpu = render(shift, nullptr);
    CHECK(relative_error(gpu.first, cpu.first) <= 1e-6);
    CHECK(relative_error(gpu.second, cpu.second) <= 1e-5);
  }
  CHECK(vulkan::residency_stats(*backend).topology_uploads == 1);
  tris.data<std::int32_t>();  // counted as a write: the kept topology is not used again
  render(0.0f, backend);
  CHECK(vulkan::residency_stats(*backend).topology_uploads == 2);
}
