// The ops' G-buffer chain on a RasterBackend, as a fit iteration runs it:
// rasterize (with rast_db) -> interpolate_with_derivatives (3 channels) and
// interpolate (3 more channels) on one G-buffer -> antialias -> loss ->
// backward (the adjoints of antialias, both interpolates and the rasterize).
//   BM_OpChain/backend/size: wall time of one iteration (host transfers
//                          included); backend 0 = the CPU kernels, 1 = Vulkan
//                          (Device::open()'s device; GRADRASTER_VULKAN_DEVICE
//                          selects). A torus (20,000 triangles) framed by
//                          bench/mesh_framing.h, size x size pixels.
//   BM_OpChain/.../kept: 1 = antialias's own welded topology kept between
//                          iterations (the op's default,
//                          ops/render/topology_cache.h); 0 = the triangles
//                          written (in place, unchanged) each iteration, so
//                          it is welded, built and uploaded again, as before
//                          the op kept it. Counter topology_uploads: per
//                          iteration (ResidencyStats), on the Vulkan backend.
//   BM_BatchChain/deferred/images: the same chain through the batch ops
//                          (rasterize_batch, interpolate_batch,
//                          antialias_batch) on the Vulkan backend, an
//                          instanced batch of `images` views of the torus
//                          at 128 x 128; deferred 1 = the batch's calls
//                          submitted without waiting and finished together
//                          (raster::DeferredCalls, the default), 0 = each
//                          call waited for (raster_backend's deferred_calls).
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "mesh_framing.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "raster/vulkan/backend.h"

namespace {

struct ChainScene {
  gr::Tensor clip, tris, colours, normals, weights;
};

ChainScene& chain_scene(int size) {
  static ChainScene s;
  static int made = 0;
  if (made == size) return s;
  const gr::raster::Mesh m = gr::raster::make_torus(200, 50);
  const std::int64_t n = m.positions.size(0);
  s.clip = gr::bench::frame_mesh(m);
  s.tris = m.triangles;
  s.colours = gr::Tensor::uniform({n, 3}, 0, 1, 3);
  s.normals = gr::Tensor::uniform({n, 3}, -1, 1, 4);
  s.weights = gr::Tensor::uniform({size, size, 3}, -1, 1, 5);
  made = size;
  return s;
}

void BM_OpChain(benchmark::State& state) {
  std::shared_ptr<const gr::raster::RasterBackend> backend;
  if (state.range(0) == 1) {
    static const std::shared_ptr<gr::vulkan::Device> device = gr::vulkan::Device::open();
    if (!device) {
      state.SkipWithError("no Vulkan device");
      return;
    }
    static const auto made = gr::vulkan::raster_backend(device);
    backend = made;
    state.SetLabel(backend->name());
  }
  const int size = static_cast<int>(state.range(1));
  ChainScene& s = chain_scene(size);
  const bool kept = state.range(2) != 0;
  const std::int64_t uploads_before = backend ? gr::vulkan::residency_stats(*backend).topology_uploads : 0;
  for (auto _ : state) {
    if (!kept) s.tris.data<std::int32_t>();  // counted as a write
    gr::Tensor clip = s.clip.detach().set_requires_grad();
    gr::Tensor colours = s.colours.detach().set_requires_grad();
    gr::RasterizeOptions ro{size, size};
    ro.derivatives = true;
    ro.backend = backend;
    const gr::GBuffer gb = gr::rasterize(clip, s.tris, ro);
    const gr::InterpolatedWithDerivatives c = gr::interpolate_with_derivatives(colours, gb, s.tris);
    const gr::Tensor n = gr::interpolate(s.normals, gb, s.tris);
    const gr::Tensor image = gr::antialias(c.values * n, gb, clip, s.tris);
    gr::backward(gr::sum(image * s.weights) + gr::sum(c.d_dx * c.d_dy));
    benchmark::DoNotOptimize(clip.grad().data<float>());
  }
  if (backend)
    state.counters["topology_uploads"] = benchmark::Counter(
        double(gr::vulkan::residency_stats(*backend).topology_uploads - uploads_before), benchmark::Counter::kAvgIterations);
}

// `images` copies of the framed torus, each turned a little about the view axis.
gr::Tensor instanced_clip(const gr::Tensor& clip, int images) {
  const std::int64_t n = clip.size(0);
  std::vector<float> out;
  for (int b = 0; b < images; ++b) {
    const float c = std::cos(0.1f * b), s = std::sin(0.1f * b);
    const float* v = clip.data<float>();
    for (std::int64_t i = 0; i < n; ++i, v += 4) out.insert(out.end(), {c * v[0] - s * v[1], s * v[0] + c * v[1], v[2], v[3]});
  }
  return gr::Tensor::from_vector<float>(out, {images, n, 4});
}

void BM_BatchChain(benchmark::State& state) {
  static const std::shared_ptr<gr::vulkan::Device> device = gr::vulkan::Device::open();
  if (!device) {
    state.SkipWithError("no Vulkan device");
    return;
  }
  const bool deferred = state.range(0) != 0;
  const int images = static_cast<int>(state.range(1)), size = 128;
  const auto backend = gr::vulkan::raster_backend(device, images, deferred);
  state.SetLabel(backend->name());
  ChainScene& s = chain_scene(size);
  const gr::Tensor clip0 = instanced_clip(s.clip, images);
  const gr::Tensor colours0 = gr::Tensor::uniform({images, s.colours.size(0), 3}, 0, 1, 6);
  const gr::Tensor weights = gr::Tensor::uniform({images, size, size, 3}, -1, 1, 7);
  for (auto _ : state) {
    gr::Tensor clip = clip0.detach().set_requires_grad();
    gr::Tensor colours = colours0.detach().set_requires_grad();
    gr::RasterizeOptions ro{size, size};
    ro.backend = backend;
    const gr::GBuffer gb = gr::rasterize_batch(clip, s.tris, ro);
    const gr::Tensor shaded = gr::interpolate_batch(colours, gb, s.tris);
    const gr::Tensor image = gr::antialias_batch(shaded, gb, clip, s.tris);
    gr::backward(gr::sum(image * weights));
    benchmark::DoNotOptimize(clip.grad().data<float>());
  }
  state.counters["deferred_calls"] = benchmark::Counter(
      double(gr::vulkan::residency_stats(*backend).deferred_calls), benchmark::Counter::kAvgIterations);
}

}  // namespace

BENCHMARK(BM_BatchChain)
    ->ArgNames({"deferred", "images"})
    ->ArgsProduct({{1, 0}, {8}})
    ->Unit(benchmark::kMillisecond);

BENCHMARK(BM_OpChain)
    ->ArgNames({"backend", "size", "kept"})
    ->ArgsProduct({{0, 1}, {256}, {1, 0}})
    ->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
