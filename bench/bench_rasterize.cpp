// Rasterize (and its adjoint) at 1024 x 1024, float32, 1 and 2 threads.
//   BM_Mesh*:      the glmark2 Stanford bunny (69,666 triangles; registered only
//                  when /usr/share/glmark2/models/bunny.obj exists) and the bunny
//                  subdivided twice (x16, ~1.1M triangles; an icosphere(6) x16
//                  stand-in without the file), framed like bench/peer_llvmpipe.
//                  Args {mesh, threads, f2b}: mesh 0 = base, 1 = x16;
//                  f2b = RasterizeOptions::front_to_back.
//   BM_TriSweep:   a torus of 10k..1M triangles at fixed framing (time vs
//                  triangle count). Args {tris, threads}.
//   BM_ScaleSweep: the bunny x4 (~280k triangles) scaled in clip x/y by
//                  scale8/8 (covered pixels ~ scale^2). Args {scale8, threads}.
// Counters: triangles, covered_px (pixels with a triangle).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "ops/ops.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "roofline.h"
#include "mesh_framing.h"

namespace {

constexpr int kSize = 1024;
constexpr const char* kBunny = "/usr/share/glmark2/models/bunny.obj";

bool have_bunny() { return std::ifstream(kBunny).good(); }

struct Scene {
  gr::Tensor clip, tris;
};

// The bunny (or stand-in) subdivided `level` times; built once per process.
const Scene& mesh_scene(int level) {
  static std::map<int, Scene> cache;
  auto it = cache.find(level);
  if (it != cache.end()) return it->second;
  gr::raster::Mesh m = have_bunny() ? gr::raster::load_obj(kBunny) : gr::raster::make_icosphere(6);
  for (int i = 0; i < level; ++i) m = gr::raster::subdivide(m);  // x4 each
  return cache[level] = Scene{gr::bench::frame_mesh(m), m.triangles};
}

// Torus of about `triangles` triangles; built once per process.
const Scene& torus_scene(std::int64_t triangles) {
  static std::map<std::int64_t, Scene> cache;
  auto it = cache.find(triangles);
  if (it != cache.end()) return it->second;
  const int minor = std::max(10, static_cast<int>(std::sqrt(triangles / 8.0)));
  const int major = static_cast<int>(triangles / (2 * minor));
  gr::raster::Mesh m = gr::raster::make_torus(major, minor, 1.0f, 0.35f);
  return cache[triangles] = Scene{gr::bench::frame_mesh(m), m.triangles};
}

// Clip x, y scaled about the view axis: the image shrinks by `scale`.
Scene scaled(const Scene& s, double scale) {
  gr::Tensor clip = s.clip.copy();
  float* c = clip.data<float>();
  for (std::int64_t i = 0; i < clip.size(0); ++i) {
    c[4 * i] = static_cast<float>(c[4 * i] * scale);
    c[4 * i + 1] = static_cast<float>(c[4 * i + 1] * scale);
  }
  return {clip, s.tris};
}

gr::RasterizeOptions options(bool front_to_back) {
  gr::RasterizeOptions o;
  o.width = o.height = kSize;
  o.front_to_back = front_to_back;
  return o;
}

// Forward only, or forward + backward with a fixed random upstream gradient on uv.
void run(benchmark::State& state, const Scene& scene, int threads, bool front_to_back, bool with_backward) {
  gr::set_num_threads(threads);
  const gr::RasterizeOptions opt = options(front_to_back);
  gr::Tensor clip = scene.clip.detach();
  if (with_backward) clip.set_requires_grad();
  gr::Tensor w_uv = gr::Tensor::uniform({kSize, kSize, 2}, -1, 1, 7);
  gr::GBuffer gb;
  for (auto _ : state) {
    gb = gr::rasterize(clip, scene.tris, opt);
    if (with_backward) {
      gr::backward(gb.uv, w_uv);
      clip.zero_grad();
    }
    benchmark::DoNotOptimize(gb.tri_id.impl());
  }
  // Roofline: clip and triangles read, the G-buffer written; the backward
  // reads uv's upstream gradient and writes clip's.
  const double forward = gr::bench::bytes_of({clip, scene.tris, gb.tri_id, gb.uv, gb.depth});
  gr::bench::report_traffic(state, with_backward ? forward + gr::bench::bytes_of({w_uv, clip}) : forward);
  gr::set_num_threads(0);
  state.counters["triangles"] = double(scene.tris.size(0));
  std::int64_t covered = 0;
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  for (std::int64_t i = 0; i < gb.tri_id.numel(); ++i) covered += id[i] != 0;
  state.counters["covered_px"] = double(covered);
}

void BM_MeshForward(benchmark::State& state) {
  run(state, mesh_scene(state.range(0) == 0 ? 0 : 2), int(state.range(1)), state.range(2) != 0, false);
}
void BM_MeshForwardBackward(benchmark::State& state) {
  run(state, mesh_scene(state.range(0) == 0 ? 0 : 2), int(state.range(1)), state.range(2) != 0, true);
}
void BM_TriSweep(benchmark::State& state) {
  run(state, torus_scene(state.range(0)), int(state.range(1)), false, false);
}
void BM_ScaleSweep(benchmark::State& state) {
  run(state, scaled(mesh_scene(1), state.range(0) / 8.0), int(state.range(1)), false, false);
}

void MeshArgs(benchmark::internal::Benchmark* b, bool with_base) {
  for (std::int64_t mesh : {0, 1}) {
    if (mesh == 0 && !with_base) continue;
    for (std::int64_t threads : {1, 2})
      for (std::int64_t f2b : {0, 1}) b->Args({mesh, threads, f2b});
  }
  b->ArgNames({"mesh", "threads", "f2b"})->Unit(benchmark::kMillisecond)->UseRealTime();
}
void TriArgs(benchmark::internal::Benchmark* b) {
  for (std::int64_t tris : {10000, 30000, 100000, 300000, 1000000})
    for (std::int64_t threads : {1, 2}) b->Args({tris, threads});
  b->ArgNames({"tris", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}
void ScaleArgs(benchmark::internal::Benchmark* b) {
  for (std::int64_t s8 : {1, 2, 4, 8})
    for (std::int64_t threads : {1, 2}) b->Args({s8, threads});
  b->ArgNames({"scale8", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

// Without the bunny file only the x16 stand-in is registered (the base
// icosphere is not "the bunny").
const bool kRegistered = [] {
  const bool base = have_bunny();
  MeshArgs(benchmark::RegisterBenchmark("BM_MeshForward", BM_MeshForward), base);
  MeshArgs(benchmark::RegisterBenchmark("BM_MeshForwardBackward", BM_MeshForwardBackward), base);
  TriArgs(benchmark::RegisterBenchmark("BM_TriSweep", BM_TriSweep));
  ScaleArgs(benchmark::RegisterBenchmark("BM_ScaleSweep", BM_ScaleSweep));
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
