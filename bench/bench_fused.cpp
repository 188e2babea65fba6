// The tape against the hand-fused pass (issue 17): the Blinn-Phong loss of
// shading_graph.h, forward + backward on 1,048,576 pixels, and the textured
// loss of textured_graph.h, both ways in one binary so one run compares them
// side by side. Each reports the compulsory
// traffic (inputs p, n, albedo, target read once; gradients of n and albedo
// written once: 18 values per pixel) as GB/s and as a fraction of the
// measured triad bandwidth (roofline.h).
#include <benchmark/benchmark.h>

#include <type_traits>

#include "fused_blinn_phong.h"
#include "fused_textured.h"
#include "ops/tensor/map_rows.h"
#include "roofline.h"

namespace {

constexpr std::int64_t kPixels = 1 << 20;

template <gr::DType D>
using Scalar = std::conditional_t<D == gr::DType::Float32, float, double>;

template <gr::DType D>
double compulsory_bytes() {
  return 18.0 * sizeof(Scalar<D>) * kPixels;
}

// Forward + backward of the Blinn-Phong loss as loss(scene) builds it.
template <gr::DType D, class Loss>
void run_blinn_phong(benchmark::State& state, Loss loss) {
  gr::set_num_threads(static_cast<int>(state.range(0)));
  auto scene = gr::bench::make_shading_scene(kPixels, D);
  const gr::bench::StoragePeak peak;
  for (auto _ : state) {
    gr::backward(loss(scene));
    benchmark::DoNotOptimize(scene.albedo.grad().data<Scalar<D>>());
    scene.n.zero_grad();
    scene.albedo.zero_grad();
    scene.light.zero_grad();
  }
  gr::bench::report_traffic(state, compulsory_bytes<D>());
  peak.report(state);
  gr::set_num_threads(0);
}

using Scene = gr::bench::ShadingScene;

template <gr::DType D>
void BM_BlinnPhongTape(benchmark::State& state) {
  run_blinn_phong<D>(state, [](const Scene& s) { return gr::bench::blinn_phong_loss(s); });
}

// The same graph through map_rows (ops/tensor/map_rows.h) in blocks of block_rows
// pixels, the loss's mean outside: the forward runs again in the adjoint.
template <gr::DType D>
void BM_BlinnPhongBlocked(benchmark::State& state) {
  run_blinn_phong<D>(state, [&](const Scene& s) {
    return gr::mean(gr::map_rows(gr::bench::blinn_phong_squared_error, {s.p, s.n, s.albedo, s.target}, {s.light, s.cam},
                                 gr::MapRowsOptions{state.range(1)}));
  });
}

// The same loss through map_rows_mean: the fused interpreter's forward and
// backward in one pass over the pixels, the gradients kept for backward().
template <gr::DType D>
void BM_BlinnPhongRowsMean(benchmark::State& state) {
  run_blinn_phong<D>(state, [](const Scene& s) {
    return gr::map_rows_mean(gr::bench::blinn_phong_squared_error, {s.p, s.n, s.albedo, s.target}, {s.light, s.cam});
  });
}

// Acc: the hand-fused pass's precision for dot products and lengths (float32:
// float, the fastest, or double, the tape's own).
template <gr::DType D, class Acc = Scalar<D>>
void BM_BlinnPhongFused(benchmark::State& state) {
  gr::set_num_threads(static_cast<int>(state.range(0)));
  auto scene = gr::bench::make_shading_scene(kPixels, D);
  gr::bench::FusedGradients<Scalar<D>> grads;
  const gr::bench::StoragePeak peak;
  for (auto _ : state) {
    gr::bench::fused_blinn_phong<Scalar<D>, Acc>(scene, grads);
    benchmark::DoNotOptimize(grads.albedo.data());
  }
  gr::bench::report_traffic(state, compulsory_bytes<D>());
  peak.report(state, 6.0 * sizeof(Scalar<D>) * kPixels);  // its gradient vectors
  gr::set_num_threads(0);
}

// The texture-heavy graph (textured_graph.h): 1024 x 1024 pixels looking up a
// 512 x 512 x 3 texture. Compulsory traffic: texture, uv, shade, target read
// once, the texture's and uv's gradients written once.
constexpr int kTexturedSide = 1024, kTextureSide = 512;

template <gr::DType D>
double textured_bytes() {
  const double texels = double(kTextureSide) * kTextureSide, pixels = double(kTexturedSide) * kTexturedSide;
  return (2 * 3 * texels + (2 + 1 + 3 + 2) * pixels) * sizeof(Scalar<D>);
}

template <gr::DType D>
void BM_TexturedTape(benchmark::State& state) {
  gr::set_num_threads(static_cast<int>(state.range(0)));
  auto scene = gr::bench::make_textured_scene(kTexturedSide, kTexturedSide, kTextureSide, D);
  const gr::bench::StoragePeak peak;
  for (auto _ : state) {
    gr::backward(gr::bench::textured_loss(scene));
    benchmark::DoNotOptimize(scene.tex.grad().data<Scalar<D>>());
    scene.tex.zero_grad();
    scene.uv.zero_grad();
  }
  gr::bench::report_traffic(state, textured_bytes<D>());
  peak.report(state);
  gr::set_num_threads(0);
}

template <gr::DType D>
void BM_TexturedFused(benchmark::State& state) {
  gr::set_num_threads(static_cast<int>(state.range(0)));
  auto scene = gr::bench::make_textured_scene(kTexturedSide, kTexturedSide, kTextureSide, D);
  gr::bench::FusedTexturedGradients<Scalar<D>> grads;
  const gr::bench::StoragePeak peak;
  for (auto _ : state) {
    gr::bench::fused_textured(scene, grads);
    benchmark::DoNotOptimize(grads.tex.data());
  }
  gr::bench::report_traffic(state, textured_bytes<D>());
  // Its gradient vectors and per-pixel scratch.
  peak.report(state, double(grads.tex.size() + grads.uv.size() + grads.g.size()) * sizeof(Scalar<D>));
  gr::set_num_threads(0);
}

}  // namespace

BENCHMARK_TEMPLATE(BM_TexturedTape, gr::DType::Float32)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_TexturedFused, gr::DType::Float32)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongTape, gr::DType::Float32)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongBlocked, gr::DType::Float32)->ArgNames({"threads", "block"})->ArgsProduct({{1, 2}, {1024, 4096, 16384}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongRowsMean, gr::DType::Float32)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongFused, gr::DType::Float32)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongFused, gr::DType::Float32, double)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongTape, gr::DType::Float64)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongBlocked, gr::DType::Float64)->ArgNames({"threads", "block"})->ArgsProduct({{1, 2}, {4096}})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongRowsMean, gr::DType::Float64)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_TEMPLATE(BM_BlinnPhongFused, gr::DType::Float64)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
