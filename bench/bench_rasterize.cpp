// Rasterize (and its adjoint) at 1024 x 1024 for procedural tori of ~10k,
// ~100k and ~1M triangles, with 1 and 2 threads. Arguments: {triangles, threads}.
#include <benchmark/benchmark.h>

#include <cmath>

#include "ops/ops.h"
#include "raster/procedural.h"

namespace {

constexpr int kSize = 1024;

// Torus with 2 * major * minor ~= triangles, seen from above at an angle.
gr::Tensor torus_clip(std::int64_t triangles, gr::Tensor* tris) {
  const int minor = triangles >= 1000000 ? 500 : triangles >= 100000 ? 200 : 50;
  const int major = static_cast<int>(triangles / (2 * minor));
  gr::raster::Mesh mesh = gr::raster::make_torus(major, minor, 1.0f, 0.35f);
  *tris = mesh.triangles;
  gr::Tensor eye = gr::Tensor::from_values({0, 1.6, 2.2}, {3});
  gr::Tensor mvp = gr::matmul(gr::perspective(0.8, 1.0, 0.1, 10.0),
                              gr::look_at(eye, gr::Tensor::zeros({3}), gr::Tensor::from_values({0, 1, 0}, {3})));
  return gr::transform_points(mesh.positions, mvp);
}

void BM_RasterizeForward(benchmark::State& state) {
  gr::Tensor tris;
  gr::Tensor clip = torus_clip(state.range(0), &tris);
  gr::set_num_threads(static_cast<int>(state.range(1)));
  gr::GBuffer gb;
  for (auto _ : state) {
    gb = gr::rasterize(clip, tris, {kSize, kSize});
    benchmark::DoNotOptimize(gb.tri_id.impl());
  }
  gr::set_num_threads(0);
  state.counters["triangles"] = double(tris.size(0));
  std::int64_t covered = 0;
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  for (std::int64_t i = 0; i < gb.tri_id.numel(); ++i) covered += id[i] != 0;
  state.counters["covered_px"] = double(covered);
}

void BM_RasterizeForwardBackward(benchmark::State& state) {
  gr::Tensor tris;
  gr::Tensor clip = torus_clip(state.range(0), &tris).detach();
  clip.set_requires_grad();
  gr::set_num_threads(static_cast<int>(state.range(1)));
  gr::Tensor weights = gr::Tensor::uniform({kSize, kSize, 2}, -1, 1, 7);
  for (auto _ : state) {
    gr::GBuffer gb = gr::rasterize(clip, tris, {kSize, kSize});
    gr::backward(gb.uv, weights);
    clip.zero_grad();
  }
  gr::set_num_threads(0);
  state.counters["triangles"] = double(tris.size(0));
}

void Args(benchmark::internal::Benchmark* b) {
  for (std::int64_t tris : {10000, 100000, 1000000})
    for (std::int64_t threads : {1, 2}) b->Args({tris, threads});
  b->ArgNames({"tris", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

}  // namespace

BENCHMARK(BM_RasterizeForward)->Apply(Args);
BENCHMARK(BM_RasterizeForwardBackward)->Apply(Args);

BENCHMARK_MAIN();
