// The ops' G-buffer chain on a Vulkan backend (raster/vulkan/backend.h):
// rasterize -> interpolate (with attribute derivatives) -> antialias -> loss
// -> backward, with the G-buffer's backend running interpolate, antialias and
// the rasterize adjoint, against the same chain on the CPU. Issue 33's rule:
// values within 1e-6 and every gradient within 1e-5 of the CPU's (relative
// to the largest), bit-identical run to run.
#include <catch2/catch.hpp>

#include <cstring>
#include <memory>
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
// the clip rows (the op's default) or by index; the position gradient boost.
struct Chain {
  int channels = 3;
  bool derivatives = true;
  bool index_topology = false;
  double boost = 1.0;
};

// Outputs and gradients of one run, as float vectors.
struct Run {
  std::vector<float> uv, image, d_dx, d_dy, grad_clip, grad_attr;
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
  const Tensor image = antialias(shaded, gb, clip, tris, ao);
  // Every output in the loss with its own weights; uv also directly (a
  // G-buffer gradient from outside interpolate), depth too.
  Tensor loss = sum(image * weights(image, 11)) + sum(gb.uv * weights(gb.uv, 12)) +
                sum(gb.depth * weights(gb.depth, 13));
  if (c.derivatives) loss = loss + sum(d_dx * weights(d_dx, 14)) + sum(d_dy * weights(d_dy, 15));
  backward(loss);
  return {values_of(gb.uv), values_of(image), values_of(d_dx), values_of(d_dy), values_of(clip.grad()),
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
  const Run again = run_chain(s, W, H, c, backend);
  REQUIRE(same_bits(gpu.uv, cpu.uv));  // the coverage and G-buffer: the CPU's bit for bit
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
