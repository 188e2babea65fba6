// Texture lookups on the Vulkan device against the CPU kernel: a 512 x 512
// grid of samples from a 2048 x 2048 x 3 texture with its full mip chain
// (12 levels), trilinear, footprints over every level (uv in [0, 1), uv
// derivatives of 2^[-3, 9] level-0 texels), float32.
//   BM_GpuTexture/backward: iteration time = the device's compute passes
//       (timestamps; the texture and samples are uploaded at every call,
//       counted apart); counters upload_ms, download_ms, host_ms (the whole
//       call). backward 0: texture_forward; 1: texture_backward (gradients
//       to the texels, uv, uv_dx, uv_dy), with its passes: samples_ms (the
//       per-sample gradients and the largest contribution), sums_ms (the
//       fixed-point sums), finish_ms (to double, the box-filter adjoint, to float).
//   BM_CpuTexture/backward/threads: raster::texture_forward / texture_backward.
// The device is Device::open()'s choice (GRADRASTER_VULKAN_DEVICE selects).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/mipmap.h"
#include "raster/texture.h"
#include "raster/vulkan/texture.h"

namespace {

constexpr int kTexture = 2048, kSamples = 512 * 512, kChannels = 3;

struct Lookups {
  std::vector<float> tex, pyramid, uv, dx, dy, grad_out;
  std::vector<float> out, g_tex, g_uv, g_dx, g_dy;
  gr::raster::MipLayout layout = gr::raster::mip_layout(kTexture, kTexture);
  Lookups() {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> value(-1.f, 1.f), unit(0.f, 1.f);
    tex.resize(std::size_t(kTexture) * kTexture * kChannels);
    for (float& x : tex) x = value(rng);
    pyramid.resize(std::size_t(layout.total_texels - std::int64_t(kTexture) * kTexture) * kChannels);
    gr::raster::mip_build(tex.data(), kChannels, layout, pyramid.data());
    for (int s = 0; s < kSamples; ++s) {
      uv.insert(uv.end(), {(s % 512 + unit(rng)) / 512.f, (s / 512 + unit(rng)) / 512.f});
      const float d = std::exp2(-3.f + 12.f * unit(rng)) / kTexture;
      dx.insert(dx.end(), {d, 0.1f * d * value(rng)});
      dy.insert(dy.end(), {0.1f * d * value(rng), d});
      for (int c = 0; c < kChannels; ++c) grad_out.push_back(value(rng));
    }
    out.resize(std::size_t(kSamples) * kChannels);
    g_tex.resize(tex.size());
    g_uv.resize(uv.size());
    g_dx.resize(uv.size());
    g_dy.resize(uv.size());
  }
  gr::raster::TextureParams<float> params() const {
    gr::raster::TextureParams<float> p;
    p.tex = tex.data();
    p.pyramid = pyramid.data();
    p.layout = layout;
    p.channels = kChannels;
    p.uv = uv.data();
    p.uv_dx = dx.data();
    p.uv_dy = dy.data();
    p.num_samples = kSamples;
    p.filter = gr::raster::Filter::Trilinear;
    return p;
  }
  gr::raster::TextureGrads<float> grads() {
    gr::raster::TextureGrads<float> g;
    g.tex = g_tex.data();
    g.uv = g_uv.data();
    g.uv_dx = g_dx.data();
    g.uv_dy = g_dy.data();
    return g;
  }
};

Lookups& lookups() {
  static Lookups l;
  return l;
}

void BM_GpuTexture(benchmark::State& state) {
  std::string why;
  static std::shared_ptr<gr::vulkan::Device> device = gr::vulkan::Device::open(&why);
  if (!device) {
    state.SkipWithError(("no Vulkan device: " + why).c_str());
    return;
  }
  Lookups& l = lookups();
  const bool backward = state.range(0) != 0;
  double upload = 0, download = 0, host = 0;
  std::vector<double> passes;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const gr::vulkan::GpuTimes t = backward
                                       ? gr::vulkan::texture_backward(*device, l.params(), l.grad_out.data(), l.grads())
                                       : gr::vulkan::texture_forward(*device, l.params(), l.out.data());
    host += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    upload += t.upload_ms;
    download += t.download_ms;
    state.SetIterationTime(t.kernels_ms * 1e-3);
    passes.resize(t.pass_ms.size());
    for (std::size_t i = 0; i < passes.size(); ++i) passes[i] += t.pass_ms[i];
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["upload_ms"] = upload / n;
  state.counters["download_ms"] = download / n;
  state.counters["host_ms"] = host / n;
  const char* names[3] = {"samples_ms", "sums_ms", "finish_ms"};
  for (std::size_t i = 0; backward && i < passes.size() && i < 3; ++i) state.counters[names[i]] = passes[i] / n;
  state.SetLabel(device->info().name);
}

void BM_CpuTexture(benchmark::State& state) {
  Lookups& l = lookups();
  gr::set_num_threads(static_cast<int>(state.range(1)));
  for (auto _ : state) {
    if (state.range(0))
      gr::raster::texture_backward(l.params(), l.grad_out.data(), l.grads());
    else
      gr::raster::texture_forward(l.params(), l.out.data());
  }
  gr::set_num_threads(0);
}

BENCHMARK(BM_GpuTexture)->ArgName("backward")->Arg(0)->Arg(1)->UseManualTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CpuTexture)
    ->ArgNames({"backward", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2, 16}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
