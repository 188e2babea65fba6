// Blinn-Phong shading graph on 1,048,576 pixels: forward alone and
// forward + backward, float32 and float64. Reports pixels/s; the ratio of the
// two times is the cost of the reverse sweep.
#include <benchmark/benchmark.h>

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
}

}  // namespace

BENCHMARK_TEMPLATE(BM_BlinnPhongForward, gr::DType::Float32)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongForwardBackward, gr::DType::Float32)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongForward, gr::DType::Float64)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongForwardBackward, gr::DType::Float64)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
