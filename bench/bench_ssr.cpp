// SSR tracers on the SSR scene at 320 x 240 (float32 G-buffer): time per full
// trace for the view-space march (steps x binary-search steps), the DDA
// (stride x binary-search steps) and the dense reference, with the mean hit
// error against the reference (pixels) and the hit count as counters. The
// table and plot of time against error come from bench/ssr_tradeoff.cpp.
#include <benchmark/benchmark.h>

#include <cmath>

#include "autodiff/tape.h"
#include "ops/render/ssr.h"
#include "ops/render/transforms.h"
#include "examples/common/ssr_scene.h"

namespace {

using namespace gr;

constexpr int kW = 320, kH = 240;

struct Fixture {
  SsrGBuffer g;
  Tensor proj;
  SsrTrace reference;
};

SsrOptions base_options() {
  SsrOptions o;
  o.max_distance = 8;
  o.thickness = 0.3;
  return o;
}

const Fixture& fixture() {
  static const Fixture f = [] {
    NoGradGuard no_grad;
    Fixture x;
    const gr::examples::SsrScene s = gr::examples::make_ssr_scene(8, 4);
    auto v3 = [](const std::array<double, 3>& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}); };
    const Tensor view = look_at(v3(s.eye), v3(s.target), v3(s.up));
    x.proj = perspective(s.fov_y, double(kW) / kH, s.near, s.far);
    const ViewSpaceMesh vs = ssr_view_space(s.mesh.positions, s.mesh.normals, view);
    x.g = ssr_gbuffer(vs.positions, vs.normals, s.colours, s.mesh.triangles, x.proj, {kW, kH});
    SsrOptions o = base_options();
    o.tracer = SsrTracer::Reference;
    x.reference = ssr_trace(x.g, x.proj, o);
    return x;
  }();
  return f;
}

// Mean distance (pixels) between the tracer's hits and the reference's where both hit.
double mean_error(const SsrTrace& t, const SsrTrace& ref) {
  const float *h = t.hit.data<float>(), *rh = ref.hit.data<float>();
  const float *xy = t.hit_xy.data<float>(), *rxy = ref.hit_xy.data<float>();
  double sum = 0;
  std::int64_t n = 0;
  for (std::int64_t k = 0; k < t.hit.numel(); ++k)
    if (h[k] && rh[k]) sum += std::hypot(xy[2 * k] - rxy[2 * k], xy[2 * k + 1] - rxy[2 * k + 1]), ++n;
  return n ? sum / n : 0;
}

void run(benchmark::State& state, const SsrOptions& o) {
  const Fixture& f = fixture();
  SsrTrace t;
  for (auto _ : state) {
    t = ssr_trace(f.g, f.proj, o);
    benchmark::DoNotOptimize(t.hit.data<float>());
  }
  state.counters["hits"] = double(t.stats.hits);
  state.counters["err_px"] = mean_error(t, f.reference);
  state.counters["samples"] = double(t.stats.samples);
}

void BM_SsrViewSpace(benchmark::State& state) {
  SsrOptions o = base_options();
  o.tracer = SsrTracer::ViewSpace;
  o.max_steps = int(state.range(0));
  o.binary_steps = int(state.range(1));
  run(state, o);
}

void BM_SsrDda(benchmark::State& state) {
  SsrOptions o = base_options();
  o.tracer = SsrTracer::Dda;
  o.max_steps = 1024;
  o.stride = double(state.range(0));
  o.jitter = o.stride > 1 ? 1.0 : 0.0;
  o.binary_steps = int(state.range(1));
  run(state, o);
}

void BM_SsrReference(benchmark::State& state) {
  SsrOptions o = base_options();
  o.tracer = SsrTracer::Reference;
  run(state, o);
}

}  // namespace

BENCHMARK(BM_SsrViewSpace)->ArgsProduct({{16, 64, 256}, {0, 4}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SsrDda)->ArgsProduct({{1, 2, 4, 8}, {0, 4}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_SsrReference)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
