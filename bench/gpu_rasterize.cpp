// The Vulkan rasterizer on the meshes of bench_rasterize (1024 x 1024): the
// glmark2 bunny (69,666 triangles; an icosphere(6) stand-in without the file)
// and the bunny subdivided twice (x16, ~1.1M triangles).
//   BM_GpuRasterize/mesh/small_box:  iteration time = the compute passes on the device
//                          (timestamps, transfers excluded; the G-buffer stays
//                          there while timed); counters upload_ms, download_ms
//                          (the transfers), host_ms (the whole call, host copies
//                          included), and differing_px: pixels whose
//                          tri_id differs from the CPU kernel's (expected 0);
//                          clear/project/depth/id/resolve/gbuffer_ms: the passes
//                          (gbuffer: nvdiffrast's rast = u, v, z/w, id).
//                          small_box: GpuRasterOptions::small_box (tuning).
//   BM_CpuRasterize/mesh/threads: the CPU kernel on the same scene, for the
//                          side-by-side figure.
//   BM_GpuChain/mesh:      nvdiffrast's "rasterize + interpolate + antialias,
//                          forward + backward": rasterize, interpolate (3
//                          channels), antialias, then the adjoints of antialias,
//                          interpolate and rasterize (the G-buffer's gradient
//                          stays on the device between the last two), on one vulkan::Frame:
//                          iteration time = the six calls' compute passes;
//                          counters transfers_ms (their uploads and downloads),
//                          host_ms, and each call's passes (*_ms).
//   BM_CpuChain/mesh/threads: the same on the CPU kernels (coverage, G-buffer,
//                          barycentric_interpolate, antialias and the adjoints).
// The device is Device::open()'s choice (GRADRASTER_VULKAN_DEVICE selects).
#include <benchmark/benchmark.h>

#include <chrono>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "mesh_framing.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/antialias.h"
#include "raster/barycentric_gbuffer.h"
#include "raster/barycentric_interpolate.h"
#include "raster/rasterize.h"
#include "raster/vulkan/frame.h"
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

const std::shared_ptr<gr::vulkan::Device>& shared_device() {
  static std::shared_ptr<gr::vulkan::Device> d = gr::vulkan::Device::open();
  return d;
}
gr::vulkan::Device* device() { return shared_device().get(); }

// Per-vertex colours and a per-pixel upstream gradient for the chains.
struct ChainInputs {
  std::vector<float> attr, grad_out;
  explicit ChainInputs(std::int64_t vertices) : grad_out(std::size_t(kSize) * kSize * 3, 1e-3f) {
    const gr::Tensor colours = gr::Tensor::uniform({vertices, 3}, 0, 1, 3);
    attr.assign(colours.data<float>(), colours.data<float>() + 3 * vertices);
  }
};

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
  gr::vulkan::Frame frame(shared_device());
  gr::vulkan::GpuTimes sum;
  sum.pass_ms.assign(6, 0.0);
  double host_ms = 0.0;
  // The G-buffer stays on the device while timed (a download and its copy
  // would leave the GPU idle, and an idle GPU lowers its clock); it comes
  // back once after the loop, for the comparison with the CPU.
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const gr::vulkan::GpuTimes t = frame.rasterize(scene.params(), options);
    host_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(t.kernels_ms * 1e-3);
    sum.upload_ms += t.upload_ms;
    sum.download_ms += t.download_ms;
    for (std::size_t i = 0; i < t.pass_ms.size() && i < 6; ++i) sum.pass_ms[i] += t.pass_ms[i];
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["upload_ms"] = sum.upload_ms / n;
  state.counters["download_ms"] = sum.download_ms / n;
  state.counters["host_ms"] = host_ms / n;
  const char* pass_names[6] = {"clear_ms", "project_ms", "depth_ms", "id_ms", "resolve_ms", "gbuffer_ms"};
  for (int i = 0; i < 6; ++i) state.counters[pass_names[i]] = sum.pass_ms[i] / n;
  frame.rasterize(scene.params(), options, g.id.data());
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

void BM_GpuChain(benchmark::State& state) {
  if (!device()) {
    state.SkipWithError("no Vulkan device");
    return;
  }
  const Scene& scene = mesh_scene(state.range(0) == 0 ? 0 : 2);
  const std::int64_t N = scene.clip.size(0), px = std::int64_t(kSize) * kSize;
  const ChainInputs in(N);
  gr::vulkan::Frame frame(shared_device());
  std::vector<float> grad_attr(N * 3), grad_clip(N * 4), grad_image(px * 3);
  const char* names[6] = {"rasterize_ms", "interpolate_ms", "antialias_ms", "antialias_bwd_ms", "interpolate_bwd_ms",
                          "rasterize_bwd_ms"};
  double transfers = 0.0, host_ms = 0.0, per_call[6] = {};
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    std::fill(grad_image.begin(), grad_image.end(), 0.0f);
    gr::vulkan::GpuTimes t[6];
    t[0] = frame.rasterize(scene.params());
    t[1] = frame.interpolate(in.attr.data(), 3);
    t[2] = frame.antialias(nullptr, 3, nullptr);
    t[3] = frame.antialias_backward(in.grad_out.data(), grad_image.data(), grad_clip.data());
    t[4] = frame.interpolate_backward(grad_image.data(), nullptr, grad_attr.data());
    t[5] = frame.rasterize_backward(nullptr, nullptr, grad_clip.data());
    host_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    double kernels = 0.0;
    for (int i = 0; i < 6; ++i) {
      kernels += t[i].kernels_ms;
      per_call[i] += t[i].kernels_ms;
      transfers += t[i].upload_ms + t[i].download_ms;
    }
    state.SetIterationTime(kernels * 1e-3);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["transfers_ms"] = transfers / n;
  state.counters["host_ms"] = host_ms / n;
  for (int i = 0; i < 6; ++i) state.counters[names[i]] = per_call[i] / n;
  state.counters["triangles"] = static_cast<double>(scene.tris.size(0));
  state.SetLabel(device()->info().name);
}

void BM_CpuChain(benchmark::State& state) {
  const Scene& scene = mesh_scene(state.range(0) == 0 ? 0 : 2);
  gr::set_num_threads(static_cast<int>(state.range(1)));
  const std::int64_t N = scene.clip.size(0), M = scene.tris.size(0), px = std::int64_t(kSize) * kSize;
  const ChainInputs in(N);
  GBuffer g;
  std::vector<float> rast(px * 4), out(px * 3), aa(px * 3), grad_attr(N * 3), grad_clip(N * 4), grad_rast(px * 4),
      grad_image(px * 3);
  const gr::raster::EdgeTopology topology = gr::raster::build_edge_topology(scene.tris.data<std::int32_t>(), M);
  gr::raster::BarycentricGBufferParams<float> gp;
  gp.clip = scene.clip.data<float>();
  gp.num_vertices = N;
  gp.tris = scene.tris.data<std::int32_t>();
  gp.num_tris = M;
  gp.width = gp.height = kSize;
  gr::raster::BarycentricInterpolateParams<float> ip;
  ip.attr = in.attr.data();
  ip.num_vertices = N;
  ip.channels = 3;
  ip.tris = gp.tris;
  ip.num_tris = M;
  ip.rast = rast.data();
  ip.pixels = px;
  ip.tri_id = g.id.data();
  gr::raster::AntialiasParams<float> ap;
  ap.image = out.data();
  ap.channels = 3;
  ap.width = ap.height = kSize;
  ap.tri_id = g.id.data();
  ap.depth = g.depth.data();
  ap.clip = gp.clip;
  ap.num_vertices = N;
  ap.tris = gp.tris;
  ap.num_tris = M;
  ap.topology = &topology;
  std::vector<gr::raster::AntialiasPair> pairs;
  for (auto _ : state) {
    std::fill(grad_rast.begin(), grad_rast.end(), 0.0f);
    std::fill(grad_image.begin(), grad_image.end(), 0.0f);
    pairs.clear();
    gr::raster::rasterize_forward(scene.params(), g.id.data(), g.uv.data(), g.depth.data());
    gr::raster::barycentric_gbuffer_forward(gp, g.id.data(), 0, rast.data(), static_cast<float*>(nullptr));
    for (std::int64_t q = 0; q < px; ++q) g.depth[q] = rast[4 * q + 2];  // z/w, as the ops pass it
    gr::raster::barycentric_interpolate_forward(ip, out.data(), static_cast<float*>(nullptr));
    gr::raster::antialias_forward(ap, aa.data(), &pairs);
    gr::raster::antialias_backward(ap, pairs, in.grad_out.data(), {grad_image.data(), grad_clip.data()});
    gr::raster::barycentric_interpolate_backward(ip, grad_image.data(), static_cast<const float*>(nullptr),
                                                 {grad_attr.data(), grad_rast.data(), nullptr});
    gr::raster::barycentric_gbuffer_backward(gp, rast.data(), grad_rast.data(), static_cast<const float*>(nullptr),
                                             grad_clip.data());
  }
  gr::set_num_threads(0);
}

BENCHMARK(BM_GpuChain)->ArgName("mesh")->Arg(0)->Arg(1)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CpuChain)
    ->ArgNames({"mesh", "threads"})
    ->ArgsProduct({{0, 1}, {2, 16}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
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
