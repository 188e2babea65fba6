// The Vulkan rasterizer on the meshes of bench_rasterize (1024 x 1024): the
// glmark2 bunny (69,666 triangles; an icosphere(6) stand-in without the file)
// and the bunny subdivided twice (x16, ~1.1M triangles).
//   BM_GpuRasterize/mesh/small_box:  iteration time = the compute passes on the device
//                          (timestamps, transfers excluded); counters upload_ms,
//                          download_ms (the transfers), host_ms (the whole call,
//                          host copies included), and differing_px: pixels whose
//                          tri_id differs from the CPU kernel's (expected 0);
//                          clear/project/depth/id/resolve_ms: the passes.
//                          small_box: GpuRasterOptions::small_box (tuning).
//   BM_CpuRasterize/mesh/threads: the CPU kernel on the same scene, for the
//                          side-by-side figure.
// The device is Device::open()'s choice (GRADRASTER_VULKAN_DEVICE selects).
#include <benchmark/benchmark.h>

#include <chrono>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "autodiff/parallel.h"
#include "mesh_framing.h"
#include "raster/obj_io.h"
#include "raster/procedural.h"
#include "raster/rasterize.h"
#include "raster/vulkan/rasterize.h"

namespace {

constexpr int kSize = 1024;
constexpr const char* kBunny = "/usr/share/glmark2/models/bunny.obj";

struct Scene {
  gr::Tensor clip, tris;
  gr::raster::RasterParams<float> params() const {
    return {clip.data<float>(), clip.size(0), tris.data<std::int32_t>(), tris.size(0),
            gr::raster::RasterSettings{kSize, kSize}};
  }
};

const Scene& mesh_scene(int level) {
  static std::map<int, Scene> cache;
  auto it = cache.find(level);
  if (it != cache.end()) return it->second;
  const char* path = std::getenv("GRADRASTER_BENCH_BUNNY");
  if (!path) path = kBunny;
  gr::raster::Mesh m = std::ifstream(path).good() ? gr::raster::load_obj(path) : gr::raster::make_icosphere(6);
  for (int i = 0; i < level; ++i) m = gr::raster::subdivide(m);
  return cache[level] = Scene{gr::bench::frame_mesh(m), m.triangles};
}

gr::vulkan::Device* device() {
  static std::shared_ptr<gr::vulkan::Device> d = gr::vulkan::Device::open();
  return d.get();
}

struct GBuffer {
  std::vector<std::int32_t> id = std::vector<std::int32_t>(kSize * kSize);
  std::vector<float> uv = std::vector<float>(2 * kSize * kSize), depth = std::vector<float>(kSize * kSize);
};

void BM_GpuRasterize(benchmark::State& state) {
  gr::vulkan::Device* dev = device();
  if (!dev) {
    state.SkipWithError("no Vulkan device");
    return;
  }
  const Scene& scene = mesh_scene(state.range(0) == 0 ? 0 : 2);
  GBuffer g;
  gr::vulkan::GpuRasterOptions options;
  options.small_box = static_cast<int>(state.range(1));
  gr::vulkan::GpuTimes t, sum;
  sum.pass_ms.assign(5, 0.0);
  double host_ms = 0.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    gr::vulkan::rasterize_forward(*dev, scene.params(), g.id.data(), g.uv.data(), g.depth.data(), options, &t);
    host_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(t.kernels_ms * 1e-3);
    sum.upload_ms += t.upload_ms;
    sum.download_ms += t.download_ms;
    for (std::size_t i = 0; i < t.pass_ms.size() && i < 5; ++i) sum.pass_ms[i] += t.pass_ms[i];
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["upload_ms"] = sum.upload_ms / n;
  state.counters["download_ms"] = sum.download_ms / n;
  state.counters["host_ms"] = host_ms / n;
  const char* pass_names[5] = {"clear_ms", "project_ms", "depth_ms", "id_ms", "resolve_ms"};
  for (int i = 0; i < 5; ++i) state.counters[pass_names[i]] = sum.pass_ms[i] / n;
  GBuffer cpu;
  gr::raster::rasterize_forward(scene.params(), cpu.id.data(), cpu.uv.data(), cpu.depth.data());
  std::int64_t differing = 0, covered = 0;
  for (std::size_t i = 0; i < cpu.id.size(); ++i) {
    differing += cpu.id[i] != g.id[i];
    covered += cpu.id[i] != 0;
  }
  state.counters["differing_px"] = static_cast<double>(differing);
  state.counters["covered_px"] = static_cast<double>(covered);
  state.counters["triangles"] = static_cast<double>(scene.tris.size(0));
  state.SetLabel(dev->info().name);
}

void BM_CpuRasterize(benchmark::State& state) {
  const Scene& scene = mesh_scene(state.range(0) == 0 ? 0 : 2);
  gr::set_num_threads(static_cast<int>(state.range(1)));
  GBuffer g;
  for (auto _ : state) gr::raster::rasterize_forward(scene.params(), g.id.data(), g.uv.data(), g.depth.data());
  gr::set_num_threads(0);
}

BENCHMARK(BM_GpuRasterize)
    ->ArgNames({"mesh", "small_box"})
    ->ArgsProduct({{0, 1}, {16, 64, 256}})
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CpuRasterize)
    ->ArgNames({"mesh", "threads"})
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Args({0, 16})
    ->Args({1, 16})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
