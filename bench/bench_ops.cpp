// One benchmark per pixel op, forward alone and forward + its own backward
// (from a fixed random upstream gradient), at 256^2, 512^2 and 1024^2, on one
// scene: an icosphere(5) (20480 triangles) covering about 35% of the screen.
// The whole iteration is in bench_iteration, rasterize alone in
// bench_rasterize, elementwise ops in bench_elementwise.
//   Args {size, backward (0/1)}; the default thread count (all cores).
// Each reports the roofline columns GB/s and of_peak (bench/roofline.h).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <vector>

#include "ops/ops.h"
#include "raster/procedural.h"
#include "roofline.h"

namespace {

using namespace gr;

struct Scene {
  Tensor clip, triangles, colours, uv, uv_dx, uv_dy, image, texture;
  AntialiasTopology topology;
  GBuffer gbuffer;
  Fragments fragments;
};

Scene make_scene(int size) {
  Scene s;
  const raster::Mesh mesh = raster::make_icosphere(5, 1.0f);
  s.triangles = mesh.triangles;
  s.topology = antialias_topology(s.triangles, mesh.positions);
  const Tensor mvp =
      matmul(perspective(0.8, 1.0, 0.1, 10.0), look_at(Tensor::from_values({0, 0, 3}, {3}),
                                                       Tensor::from_values({0, 0, 0}, {3}),
                                                       Tensor::from_values({0, 1, 0}, {3})));
  s.clip = transform_points(mesh.positions, mvp).set_requires_grad();
  s.colours = Tensor::uniform({mesh.num_vertices(), 3}, 0, 1, 1).set_requires_grad();
  s.texture = Tensor::uniform({512, 512, 3}, 0, 1, 3).set_requires_grad();
  {
    NoGradGuard no_grad;
    RasterizeOptions raster{size, size};
    raster.derivatives = true;
    s.gbuffer = rasterize(s.clip, s.triangles, raster);
    s.fragments = fragments(s.gbuffer);
    const Tensor uv_attr = Tensor::uniform({mesh.num_vertices(), 2}, 0, 1, 2);
    InterpolatedWithDerivatives uv = interpolate_with_derivatives(uv_attr, s.gbuffer, s.triangles);
    s.uv = uv.values;
    s.uv_dx = uv.d_dx;
    s.uv_dy = uv.d_dy;
    s.image = interpolate(s.colours, s.gbuffer, s.triangles);
  }
  s.uv.set_requires_grad();
  s.image.set_requires_grad();
  return s;
}

// Times op(); with Args backward = 1, also its reverse sweep. With `inputs`,
// reports the roofline columns (bench/roofline.h): inputs read and the output
// written once, plus with the backward the upstream gradient read and the
// inputs' gradients written once.
void time_op(benchmark::State& state, const std::function<Tensor()>& op, const std::vector<Tensor>& inputs = {}) {
  const bool with_backward = state.range(1) != 0;
  Tensor upstream;
  double out_bytes = 0;
  for (auto _ : state) {
    Tensor out = op();
    out_bytes = bench::bytes_of({out});
    if (!with_backward) {
      Tape::current().clear();
      continue;
    }
    if (!upstream.defined()) upstream = Tensor::uniform(out.shape(), -1, 1, 7, out.dtype());
    backward(out, upstream);
  }
  if (inputs.empty()) return;
  const double forward = bench::bytes_of(inputs) + out_bytes;
  bench::report_traffic(state, with_backward ? forward + out_bytes + bench::grad_bytes(inputs) : forward);
}

void BM_Interpolate(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  time_op(state, [&] { return interpolate(s.colours, s.gbuffer, s.triangles); },
          {s.colours, s.clip, s.gbuffer.tri_id, s.gbuffer.uv, s.triangles});
}

void BM_InterpolateFragments(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  time_op(state, [&] { return interpolate(s.colours, s.fragments, s.triangles); },
          {s.colours, s.clip, s.fragments.tri_id, s.fragments.uv, s.fragments.pixel_index, s.triangles});
}

void BM_Antialias(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  AntialiasOptions aa;
  aa.topology = s.topology;
  time_op(state, [&] { return antialias(s.image, s.gbuffer, s.clip, s.triangles, aa); },
          {s.image, s.gbuffer.tri_id, s.gbuffer.depth, s.clip, s.triangles});
}

// antialias with no topology given: the op welds one from the clip rows and
// keeps it for the next call on the same triangles (ops/render/topology_cache.h).
//   Args {size, backward, kept}: kept = 1 reuses it (the weld checked, O(N));
//   kept = 0 writes the triangles (in place, no change) before each call, so
//   the op welds and builds it again, as it did at every call before.
void BM_AntialiasOwnTopology(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  const bool kept = state.range(2) != 0;
  time_op(state, [&] {
    if (!kept) s.triangles.data<std::int32_t>();  // counted as a write
    return antialias(s.image, s.gbuffer, s.clip, s.triangles);
  });
}

// visibility_antialias on the same image (one closed sphere: silhouettes only,
// so the cost of locating boundaries from both surfaces against antialias's).
void BM_VisibilityAntialias(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  VisibilityAntialiasOptions options;
  options.topology = s.topology;
  time_op(state, [&] { return visibility_antialias(s.image, s.gbuffer, s.clip, s.triangles, options); },
          {s.image, s.gbuffer.tri_id, s.gbuffer.depth, s.clip, s.triangles});
}

void BM_TextureBilinear(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  time_op(state, [&] { return texture(s.texture, s.uv); }, {s.texture, s.uv});
}

// The lookup alone, as inference runs it (nothing recorded, no Jacobian kept).
void BM_TextureBilinearNoGrad(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  NoGradGuard no_grad;
  for (auto _ : state) benchmark::DoNotOptimize(texture(s.texture, s.uv));
}

void BM_TextureTrilinear(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  TextureOptions options;
  options.filter = raster::Filter::Trilinear;
  time_op(state, [&] { return texture(s.texture, s.uv, options, s.uv_dx, s.uv_dy); },
          {s.texture, s.uv, s.uv_dx, s.uv_dy});
}

// Cube map (6 faces of 256 x 256) looked up per pixel in the direction of the
// sphere's interpolated clip-space position (0 on the background).
void BM_CubeTextureBilinear(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  const Tensor faces = Tensor::uniform({6, 256, 256, 3}, 0, 1, 4).set_requires_grad();
  Tensor dir;
  {
    NoGradGuard no_grad;
    dir = interpolate(s.clip.detach(), s.gbuffer, s.triangles);
    dir = slice(dir, 2, 0, 3);
  }
  dir.set_requires_grad();
  time_op(state, [&] { return cube_texture(faces, dir); }, {faces, dir});
}

// Trilinear cube map of 6 faces of 1024 x 1024 (RGB, per-face pyramids built
// in the forward), looked up as above with the LOD from a bias in [0, 2]: the
// adjoint's level-0 sums are listed by piece (raster/detail/texel_pieces.h),
// so its double sums are levels 1.. alone (48 MiB, not 192; run it under
// /usr/bin/time -v for the minor faults and the peak).
void BM_CubeTextureTrilinear(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  const Tensor faces = Tensor::uniform({6, 1024, 1024, 3}, 0, 1, 4).set_requires_grad();
  Tensor dir, bias;
  {
    NoGradGuard no_grad;
    dir = slice(interpolate(s.clip.detach(), s.gbuffer, s.triangles), 2, 0, 3);
    bias = Tensor::uniform({dir.shape()[0], dir.shape()[1]}, 0, 2, 5);
  }
  dir.set_requires_grad();
  CubeTextureOptions options;
  options.filter = CubeFilter::Trilinear;
  time_op(state, [&] { return cube_texture(faces, dir, options, Tensor(), bias); }, {faces, dir});
}

// Bilinear texture forward+backward against its forward alone (issue 11's
// goal: at most 3x), timed in alternating iterations of one run so that both
// see the same machine: counters fwd_ms, fwd_bwd_ms (medians), ratio (of the
// medians) and ratio_of_min (of the fastest iterations).
void BM_TextureBilinearRatio(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  Tensor upstream;
  std::vector<double> fwd, fwd_bwd;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    texture(s.texture, s.uv);
    Tape::current().clear();
    const auto t1 = Clock::now();
    const Tensor out = texture(s.texture, s.uv);
    if (!upstream.defined()) upstream = Tensor::uniform(out.shape(), -1, 1, 7, out.dtype());
    backward(out, upstream);
    const auto t2 = Clock::now();
    fwd.push_back(ms(t1 - t0));
    fwd_bwd.push_back(ms(t2 - t1));
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  state.counters["fwd_ms"] = median(fwd);
  state.counters["fwd_bwd_ms"] = median(fwd_bwd);
  state.counters["ratio"] = median(fwd_bwd) / median(fwd);
  // Fastest of each (what a quiet machine gives, on a noisy one).
  state.counters["ratio_of_min"] =
      *std::min_element(fwd_bwd.begin(), fwd_bwd.end()) / *std::min_element(fwd.begin(), fwd.end());
}

void BM_DownsampleBox2(benchmark::State& state) {
  Scene s = make_scene(static_cast<int>(state.range(0)));
  time_op(state, [&] { return downsample_box(s.image, 2); }, {s.image});
}

// 16 views of the icosphere(4) at 128 x 128.
Tensor sixteen_views(const raster::Mesh& mesh) {
  const Tensor proj = perspective(0.8, 1.0, 0.1, 10.0);
  std::vector<Tensor> views;
  for (int b = 0; b < 16; ++b) {
    const double a = 0.39 * b;
    const Tensor eye = Tensor::from_values({3 * std::sin(a), 0.5, 3 * std::cos(a)}, {3});
    views.push_back(transform_points(mesh.positions, matmul(proj, look_at(eye, Tensor::from_values({0, 0, 0}, {3}),
                                                                          Tensor::from_values({0, 1, 0}, {3})))));
  }
  return stack(views, 0);
}

// 16 images of 128 x 128 (16 views of the icosphere, turned about y) through
// rasterize + interpolate + antialias, forward + backward: one batched call
// (Args batched = 1) against 16 single-image calls.
void BM_Batch16x128(benchmark::State& state) {
  const bool batched = state.range(0) != 0;
  const raster::Mesh mesh = raster::make_icosphere(4, 1.0f);
  const Tensor clip = sixteen_views(mesh).set_requires_grad();
  const Tensor colours = Tensor::uniform({mesh.num_vertices(), 3}, 0, 1, 1).set_requires_grad();
  AntialiasOptions aa;
  aa.topology = antialias_topology(mesh.triangles, mesh.positions);
  const RasterizeOptions size{128, 128};
  for (auto _ : state) {
    if (batched) {
      const GBuffer g = rasterize_batch(clip, mesh.triangles, size);
      backward(sum(antialias_batch(interpolate_batch(colours, g, mesh.triangles), g, clip, mesh.triangles, aa)));
    } else {
      Tensor loss = Tensor::scalar(0.0);
      for (int b = 0; b < 16; ++b) {
        const Tensor c = reshape(slice(clip, 0, b, b + 1), {mesh.num_vertices(), 4});
        const GBuffer g = rasterize(c, mesh.triangles, size);
        loss = add(loss, sum(antialias(interpolate(colours, g, mesh.triangles), g, c, mesh.triangles, aa)));
      }
      backward(loss);
    }
  }
}

// Depth peeling of 16 images of 128 x 128, two layers each, forward + backward
// of the layers' depth: one batched peeler (batched = 1) against 16 peelers.
void BM_DepthPeel16x128(benchmark::State& state) {
  const bool batched = state.range(0) != 0;
  const raster::Mesh mesh = raster::make_icosphere(4, 1.0f);
  const Tensor clip = sixteen_views(mesh).set_requires_grad();
  const RasterizeOptions size{128, 128};
  for (auto _ : state) {
    Tensor loss = Tensor::scalar(0.0);
    if (batched) {
      DepthPeeler peeler = DepthPeeler::instanced(clip, mesh.triangles, size);
      for (int layer = 0; layer < 2; ++layer) loss = add(loss, sum(peeler.rasterize_next_layer().depth));
    } else {
      for (int b = 0; b < 16; ++b) {
        DepthPeeler peeler(reshape(slice(clip, 0, b, b + 1), {mesh.num_vertices(), 4}), mesh.triangles, size);
        for (int layer = 0; layer < 2; ++layer) loss = add(loss, sum(peeler.rasterize_next_layer().depth));
      }
    }
    backward(loss);
  }
}

// A 256 x 256 x 3 texture per image looked up bilinearly at 16 images of
// 128 x 128 random uv, forward + backward: one call with tex [16, 256, 256, 3]
// (batched = 1) against 16 calls.
void BM_TexturePerImage16x128(benchmark::State& state) {
  const bool batched = state.range(0) != 0;
  const Tensor tex = Tensor::uniform({16, 256, 256, 3}, 0, 1, 5).set_requires_grad();
  const Tensor uv = Tensor::uniform({16, 128, 128, 2}, 0, 1, 6).set_requires_grad();
  for (auto _ : state) {
    Tensor loss = Tensor::scalar(0.0);
    if (batched) {
      loss = sum(texture(tex, uv));
    } else {
      for (int b = 0; b < 16; ++b)
        loss = add(loss, sum(texture(reshape(slice(tex, 0, b, b + 1), {256, 256, 3}),
                                     reshape(slice(uv, 0, b, b + 1), {128, 128, 2}))));
    }
    backward(loss);
  }
}

void Sizes(benchmark::internal::Benchmark* b) {
  for (std::int64_t size : {256, 512, 1024})
    for (std::int64_t with_backward : {0, 1}) b->Args({size, with_backward});
  b->ArgNames({"size", "backward"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(BM_Interpolate)->Apply(Sizes);
BENCHMARK(BM_InterpolateFragments)->Apply(Sizes);
BENCHMARK(BM_Antialias)->Apply(Sizes);
BENCHMARK(BM_VisibilityAntialias)->Apply(Sizes);
BENCHMARK(BM_AntialiasOwnTopology)
    ->ArgNames({"size", "backward", "kept"})
    ->ArgsProduct({{256}, {0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_TextureBilinear)->Apply(Sizes);
BENCHMARK(BM_TextureBilinearNoGrad)->ArgName("size")->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TextureTrilinear)->Apply(Sizes);
BENCHMARK(BM_CubeTextureBilinear)->Apply(Sizes);
BENCHMARK(BM_CubeTextureTrilinear)->Apply(Sizes);
BENCHMARK(BM_DownsampleBox2)->Apply(Sizes);
BENCHMARK(BM_TextureBilinearRatio)->ArgName("size")->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Batch16x128)->ArgName("batched")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DepthPeel16x128)->ArgName("batched")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TexturePerImage16x128)->ArgName("batched")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
