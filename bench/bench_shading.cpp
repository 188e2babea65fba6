// Blinn-Phong shading graph on 1,048,576 pixels: forward alone and
// forward + backward, float32 and float64. Reports pixels/s and the roofline
// columns (inputs p, n, albedo, target read once: 12 values a pixel; with the
// backward also the gradients of n and albedo written once: 18); the ratio of
// the two times is the cost of the reverse sweep.
#include <benchmark/benchmark.h>

#include "roofline.h"
#include "shading_graph.h"

namespace {

constexpr std::int64_t kPixels = 1 << 20;

template <gr::DType D>
void BM_BlinnPhongForward(benchmark::State& state) {
  auto scene = gr::bench::make_shading_scene(kPixels, D);
  for (auto _ : state) {
    gr::NoGradGuard no_grad;
    benchmark::DoNotOptimize(gr::bench::blinn_phong_loss(scene).item());
  }
  state.SetItemsProcessed(state.iterations() * kPixels);
  gr::bench::report_traffic(state, gr::bench::bytes_of({scene.p, scene.n, scene.albedo, scene.target}));
}

template <gr::DType D>
void BM_BlinnPhongForwardBackward(benchmark::State& state) {
  auto scene = gr::bench::make_shading_scene(kPixels, D);
  for (auto _ : state) {
    gr::Tensor loss = gr::bench::blinn_phong_loss(scene);
    gr::backward(loss);
    benchmark::DoNotOptimize(scene.albedo.grad().data<std::conditional_t<D == gr::DType::Float32, float, double>>());
    scene.n.zero_grad();
    scene.albedo.zero_grad();
    scene.light.zero_grad();
  }
  state.SetItemsProcessed(state.iterations() * kPixels);
  gr::bench::report_traffic(state, gr::bench::bytes_of({scene.p, scene.n, scene.albedo, scene.target, scene.n,
                                                        scene.albedo}));
}

}  // namespace

BENCHMARK_TEMPLATE(BM_BlinnPhongForward, gr::DType::Float32)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongForwardBackward, gr::DType::Float32)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongForward, gr::DType::Float64)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongForwardBackward, gr::DType::Float64)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
