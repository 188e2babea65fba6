// What the exact box-filtered image costs against the antialias op (issue 13:
// 1% position-gradient error at 1x asks for the box-filtered image itself,
// its goal on cost is at most 1.5x the antialias op's forward + backward;
// docs/time_error.md, "What 1% at 1x would cost"). On each time_error scene
// at 1x (128 x 128, float64), by scene index (time_error's order: torus,
// intersection, occlusion, open_culled):
//   BM_AntialiasOp/scene/visibility antialias (visibility 0) or visibility_antialias (1, the same op
//                                   with options.visibility), forward + backward (a fixed random
//                                   upstream gradient)
//   BM_PointSampled/scene           rasterize + interpolate, forward + backward (the image both blend)
//   BM_ExactImage/scene/order/boundary
//                                   the exact reference (bench/exact_reference), forward only, at
//                                   quadrature order 1 (areas and centroid values only) and 8
//                                   (time_error's), on every pixel (boundary 0) or only on those
//                                   holding a visibility boundary (1; bench/time_error_regions.h)
#include <benchmark/benchmark.h>

#include <functional>

#include "autodiff/tape.h"
#include "bench/time_error_exact.h"
#include "bench/time_error_regions.h"
#include "bench/time_error_scene.h"
#include "ops/ops.h"

namespace {

using namespace gr;
using bench::TimeErrorScene;

const TimeErrorScene& scene_at(std::int64_t index) {
  static const std::vector<TimeErrorScene> scenes = [] {
    std::vector<TimeErrorScene> all;
    for (const std::string& name : bench::time_error_scene_names()) all.emplace_back(name);
    return all;
  }();
  return scenes.at(static_cast<std::size_t>(index));
}

// The scene's 1x render inputs: clip positions and vertex colours (both
// requiring grad), its G-buffer and the point-sampled image.
struct Inputs {
  Tensor clip, colours, image;
  GBuffer gbuffer;
};

// The scene's 1x rasterization and interpolation, as its render does them.
RasterizeOptions raster_options(const TimeErrorScene& scene) {
  RasterizeOptions options;
  options.width = scene.width(), options.height = scene.height(), options.cull = scene.cull();
  return options;
}
InterpolateOptions interpolation(const TimeErrorScene& scene) {
  InterpolateOptions options;
  options.background = scene.background();
  return options;
}

Inputs inputs_of(const TimeErrorScene& scene) {
  Inputs in;
  NoGradGuard no_grad;
  in.clip = scene.clip_positions(scene.points()).set_requires_grad();
  in.colours = scene.vertex_colours(scene.colours()).set_requires_grad();
  in.gbuffer = rasterize(in.clip, scene.triangles(), raster_options(scene));
  in.image = interpolate(in.colours, in.gbuffer, scene.triangles(), interpolation(scene)).set_requires_grad();
  return in;
}

// op() and its backward from a fixed random upstream gradient, per iteration.
void time_forward_backward(benchmark::State& state, const std::function<Tensor()>& op) {
  Tensor upstream;
  for (auto _ : state) {
    const Tensor out = op();
    if (!upstream.defined()) upstream = Tensor::uniform(out.shape(), -1, 1, 7, out.dtype());
    backward(out, upstream);
  }
}

void BM_AntialiasOp(benchmark::State& state) {
  const TimeErrorScene& scene = scene_at(state.range(0));
  state.SetLabel(scene.name());
  const Inputs in = inputs_of(scene);
  AntialiasOptions options;
  options.topology = scene.topology();
  options.visibility = state.range(1) != 0;
  time_forward_backward(state, [&] { return antialias(in.image, in.gbuffer, in.clip, scene.triangles(), options); });
}

void BM_PointSampled(benchmark::State& state) {
  const TimeErrorScene& scene = scene_at(state.range(0));
  state.SetLabel(scene.name());
  const Inputs in = inputs_of(scene);
  const RasterizeOptions options = raster_options(scene);
  const InterpolateOptions interpolate_options = interpolation(scene);
  time_forward_backward(state, [&] {
    const GBuffer gb = rasterize(in.clip, scene.triangles(), options);
    return interpolate(in.colours, gb, scene.triangles(), interpolate_options);
  });
}

void BM_ExactImage(benchmark::State& state) {
  const TimeErrorScene& scene = scene_at(state.range(0));
  state.SetLabel(scene.name());
  bench::ExactReferenceOptions options;
  options.quadrature_order = static_cast<int>(state.range(1));
  if (state.range(2)) options.only_pixels = bench::boundary_pixels(bench::pixel_regions(scene, scene.points()));
  NoGradGuard no_grad;
  for (auto _ : state)
    benchmark::DoNotOptimize(bench::exact_scene_image(scene, scene.points(), scene.colours(), options).image);
}

BENCHMARK(BM_AntialiasOp)->ArgNames({"scene", "visibility"})->ArgsProduct({{0, 1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PointSampled)->ArgName("scene")->DenseRange(0, 3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ExactImage)->ArgNames({"scene", "order", "boundary"})->ArgsProduct({{0, 1, 2, 3}, {1, 8}, {0, 1}})
    ->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
