// The full inverse-rendering iteration (issue 6), as examples/fit runs it:
//   clip = transform_points(positions, mvp) -> rasterize -> interpolate colours
//   and normals -> Blinn-Phong -> composite over the background -> antialias
//   -> MSE against a fixed target -> backward to positions and colours,
// on an icosphere(5) (20480 triangles), in image mode (shading on every pixel)
// and fragment mode (ops/render/fragments.h: shading on covered pixels only).
//
// BM_IterationForward:         the recorded forward (tape cleared, no backward).
// BM_IterationForwardBackward: forward + backward; the ratio of the two times
//                              is the cost of the reverse sweep.
//   Args {size, threads, fragment_mode}. Counters: covered (fraction of
//   pixels), fresh_allocs_iter2 (storage_stats().fresh_allocations over the
//   timed iterations, after one warm-up iteration: should be 0), and the
//   roofline columns GB/s, of_peak (bench/roofline.h) of the compulsory
//   traffic: mesh, colours and target read once, plus with the backward the
//   positions' and colours' gradients written once.
// BM_IterationCoverage:        forward + backward at 1024 x 1024, 1 thread, with
//   the sphere scaled to cover about 5%, 25% or 75% of the screen.
//   Args {coverage_percent, fragment_mode}.
#include <benchmark/benchmark.h>

#include <cmath>

#include "ops/ops.h"
#include "raster/procedural.h"
#include "roofline.h"

namespace {

using namespace gr;

constexpr double kFov = 0.8;       // vertical field of view (radians)
constexpr double kDistance = 3.0;  // camera distance from the sphere's centre

struct Scene {
  Tensor positions, colours, triangles, mvp, light, half, background, target;
  AntialiasTopology topology;
  int size = 0;
};

// Sphere radius whose projection covers `coverage` of the (square) screen:
// projected NDC radius r = sqrt(4 c / pi) = tan(asin(R / d)) / tan(fov / 2).
double radius_for_coverage(double coverage) {
  const double r = std::sqrt(4.0 * coverage / M_PI);
  return kDistance * std::sin(std::atan(r * std::tan(0.5 * kFov)));
}

Tensor vec3(double x, double y, double z) { return Tensor::from_values({x, y, z}, {3}); }

// One image of the scene (recorded when positions / colours require grad).
Tensor render(const Scene& s, const Tensor& positions, const Tensor& colours, bool fragment_mode,
              double* covered = nullptr) {
  const Tensor clip = transform_points(positions, s.mvp);
  const GBuffer gb = rasterize(clip, s.triangles, {s.size, s.size});
  const Tensor normals = normalize(positions);  // a sphere's vertex normals, differentiable
  // colour = albedo (0.2 + 0.8 max(n.l, 0)) + 0.4 max(n.h, 0)^32 (directional light, distant viewer).
  auto shade = [&](const Tensor& albedo, const Tensor& normal_raw) {
    const Tensor n = normalize(normal_raw);
    return albedo * (0.2 + 0.8 * maximum(dot(n, s.light), 0.0)) + 0.4 * pow(maximum(dot(n, s.half), 0.0), 32.0);
  };
  Tensor composited;
  if (fragment_mode) {
    const Fragments fr = fragments(gb);
    if (covered) *covered = double(fr.count()) / (double(s.size) * s.size);
    composited = to_image(shade(interpolate(colours, fr, s.triangles), interpolate(normals, fr, s.triangles)),
                          fr, s.background);
  } else {
    const Tensor shaded =
        shade(interpolate(colours, gb, s.triangles), interpolate(normals, gb, s.triangles));
    const Tensor coverage = reshape(greater(cast(gb.tri_id, DType::Float32), Tensor::scalar(0.0)), {s.size, s.size, 1});
    composited = shaded * coverage + s.background * (1.0 - coverage);
    if (covered) *covered = sum(coverage).item() / (double(s.size) * s.size);
  }
  AntialiasOptions aa;
  aa.topology = s.topology;
  return antialias(composited, gb, clip, s.triangles, aa);
}

Scene make_scene(int size, double coverage) {
  Scene s;
  s.size = size;
  raster::Mesh mesh = raster::make_icosphere(5, static_cast<float>(radius_for_coverage(coverage)));
  s.positions = mesh.positions.copy().set_requires_grad();
  s.triangles = mesh.triangles;
  s.colours = Tensor::uniform({mesh.num_vertices(), 3}, 0.2, 0.8, 11).set_requires_grad();
  const Tensor eye = vec3(0.0, 0.0, kDistance);
  s.mvp = matmul(perspective(kFov, 1.0, 0.1, 10.0), look_at(eye, vec3(0, 0, 0), vec3(0, 1, 0)));
  s.light = normalize(vec3(0.4, 0.7, 0.6));
  s.half = normalize(s.light + vec3(0, 0, 1));
  s.background = vec3(0.1, 0.15, 0.2);
  s.topology = antialias_topology(s.triangles, s.positions);
  // Target: the same sphere, slightly larger, with other colours.
  NoGradGuard no_grad;
  s.target = render(s, s.positions * 1.03, Tensor::uniform({mesh.num_vertices(), 3}, 0.2, 0.8, 12), false).copy();
  return s;
}

Tensor iteration_loss(const Scene& s, bool fragment_mode, double* covered = nullptr) {
  return mean(pow(render(s, s.positions, s.colours, fragment_mode, covered) - s.target, 2.0));
}

// One warm-up iteration, then the timed ones; counts fresh allocations in the timed part.
template <class Step>
void run(benchmark::State& state, Scene& s, bool fragment_mode, bool with_backward, Step step) {
  double covered = 0;
  {
    Tensor loss = iteration_loss(s, fragment_mode, &covered);
    backward(loss);
    s.positions.zero_grad();
    s.colours.zero_grad();
  }
  const std::int64_t fresh0 = storage_stats().fresh_allocations;
  for (auto _ : state) step();
  state.counters["covered"] = covered;
  state.counters["fresh_allocs_iter2"] = double(storage_stats().fresh_allocations - fresh0);
  const double read = bench::bytes_of({s.positions, s.colours, s.triangles, s.target});
  bench::report_traffic(state, with_backward ? read + bench::bytes_of({s.positions, s.colours}) : read);
}

void forward_step(const Scene& s, bool fragment_mode) {
  Tensor loss = iteration_loss(s, fragment_mode);
  benchmark::DoNotOptimize(loss.item());
  Tape::current().clear();
}

void forward_backward_step(Scene& s, bool fragment_mode) {
  Tensor loss = iteration_loss(s, fragment_mode);
  backward(loss);
  benchmark::DoNotOptimize(s.positions.grad().data<float>());
  s.positions.zero_grad();
  s.colours.zero_grad();
}

constexpr double kDefaultCoverage = 0.35;

void BM_IterationForward(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)), kDefaultCoverage);
  const bool frag = state.range(2) != 0;
  set_num_threads(static_cast<int>(state.range(1)));
  run(state, s, frag, false, [&] { forward_step(s, frag); });
  set_num_threads(0);
}

void BM_IterationForwardBackward(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)), kDefaultCoverage);
  const bool frag = state.range(2) != 0;
  set_num_threads(static_cast<int>(state.range(1)));
  run(state, s, frag, true, [&] { forward_backward_step(s, frag); });
  set_num_threads(0);
}

void BM_IterationCoverage(benchmark::State& state) {
  Scene s = make_scene(1024, state.range(0) / 100.0);
  const bool frag = state.range(1) != 0;
  set_num_threads(1);
  run(state, s, frag, true, [&] { forward_backward_step(s, frag); });
  set_num_threads(0);
}

void SizeArgs(benchmark::internal::Benchmark* b) {
  for (std::int64_t size : {256, 512, 1024})
    for (std::int64_t threads : {1, 2})
      for (std::int64_t frag : {0, 1}) b->Args({size, threads, frag});
  b->ArgNames({"size", "threads", "fragments"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

void CoverageArgs(benchmark::internal::Benchmark* b) {
  for (std::int64_t pct : {5, 25, 75})
    for (std::int64_t frag : {0, 1}) b->Args({pct, frag});
  b->ArgNames({"coverage_pct", "fragments"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

}  // namespace

BENCHMARK(BM_IterationForward)->Apply(SizeArgs);
BENCHMARK(BM_IterationForwardBackward)->Apply(SizeArgs);
BENCHMARK(BM_IterationCoverage)->Apply(CoverageArgs);

BENCHMARK_MAIN();
