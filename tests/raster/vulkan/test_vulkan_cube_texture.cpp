// The GPU's cube-map lookups and their adjoint (raster/vulkan/cube_texture.h)
// against the CPU kernel (raster/cube_texture.h) on the same inputs: every
// filter, faces of 1, 2, 5 and 16 texels (odd mip chains), random directions
// of magnitudes 2^-100 to 2^100 and the hard ones (exactly on face edges and
// cube corners, axis-aligned, on texel centres and edges, the zero vector),
// footprints from dir_da of zero, equal, exactly 2^k texels and beyond the
// last level, the LOD from the bias alone, a bias on top, fewer levels
// (max_mip_level 2 and 0); the cube_texture op on a Vulkan backend (every
// filter); the same bits run after run; accumulation; bad input.
//
// Samples: bit for bit (nearest, bilinear), within 1e-6 relative (mipmapped).
// Gradients (texels, dir, dir_da, bias): each within 1e-5 relative to itself
// with an absolute floor of 1e-2 of the tensor's largest (the measure of
// test_vulkan_texture.cpp), against the CPU kernel in float64 on the same
// float32 inputs.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/base/error.h"
#include "ops/ops.h"
#include "raster/cube_texture.h"
#include "raster/mipmap.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/cube_texture.h"
#include "raster/vulkan/scenes.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

// One cube-map call's host inputs.
struct CubeLookup {
  int size = 0;
  std::int64_t C = 1, N = 0;
  std::vector<float> faces, pyramid, dir, da, bias, grad_out;
  MipLayout layout;
  CubeFilter filter = CubeFilter::Bilinear;

  template <class T, class Arrays>
  CubeTextureParams<T> params_of(const Arrays& a) const {
    CubeTextureParams<T> p;
    p.faces = a.faces.data();
    p.pyramid = a.pyramid.empty() ? nullptr : a.pyramid.data();
    p.layout = layout;
    p.channels = C;
    p.dir = a.dir.data();
    p.dir_da = a.da.empty() ? nullptr : a.da.data();
    p.mip_level_bias = a.bias.empty() ? nullptr : a.bias.data();
    p.num_samples = N;
    p.filter = filter;
    return p;
  }
  CubeTextureParams<float> params() const { return params_of<float>(*this); }
  std::string describe() const {
    std::ostringstream o;
    o << "6x" << size << "x" << size << "x" << C << ", " << N << " samples, filter " << int(filter)
      << (da.empty() ? "" : ", dir_da") << (bias.empty() ? "" : ", bias");
    return o.str();
  }
};

// Appends direction d with, for the mipmapped filters, a footprint dir_da of
// `texels` face texels per pixel step (kind: 0 zero, 1 dX = dY, 2 along one
// axis only, else random), scaled by the direction's length so that the LOD
// does not depend on it.
void add_sample(CubeLookup& l, const double d[3], double texels, int kind, std::mt19937& rng) {
  std::uniform_real_distribution<double> sign(-1.0, 1.0);
  for (int k = 0; k < 3; ++k) l.dir.push_back(float(d[k]));
  if (!is_mipmapped(l.filter)) return;
  const double q = std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])});
  const double step = 2.0 * q * texels / l.size;
  double da[6];
  for (double& x : da) x = step * sign(rng);
  if (kind == 0) std::fill(da, da + 6, 0.0);
  if (kind == 1) da[1] = da[0], da[3] = da[2], da[5] = da[4];
  if (kind == 2) std::fill(da, da + 6, 0.0), da[2 * int(sign(rng) * 1.5 + 1.5)] = step;
  for (double x : da) l.da.push_back(float(x));
}

// The base of a lookup: random faces (and their pyramids), random incoming
// gradients set after the samples by finish().
CubeLookup cube_base(int size, std::int64_t C, CubeFilter filter, unsigned seed, int max_level = -1) {
  CubeLookup l;
  l.size = size, l.C = C, l.filter = filter;
  l.faces = random_values(std::size_t(6) * size * size * C, seed + 1);
  l.layout = mip_layout(size, size, is_mipmapped(filter) ? max_level : 0);
  if (l.layout.count() > 1) {
    l.pyramid.resize(6 * (l.layout.total_texels - std::int64_t(size) * size) * C);
    cube_mip_build(l.faces.data(), C, l.layout, l.pyramid.data());
  }
  return l;
}

// Sample count, incoming gradients (every 7th sample's zero), a bias when asked.
void finish(CubeLookup& l, unsigned seed, bool bias) {
  l.N = static_cast<std::int64_t>(l.dir.size() / 3);
  l.grad_out = random_values(std::size_t(l.N) * l.C, seed + 2);
  for (std::int64_t s = 0; s < l.N; s += 7)
    for (std::int64_t c = 0; c < l.C; ++c) l.grad_out[s * l.C + c] = 0.f;
  if (bias) {
    l.bias = random_values(std::size_t(l.N), seed + 3);
    for (float& b : l.bias) b *= 4.f;  // across the levels and past both ends
  }
}

// N random directions (Gaussian, lengths 2^[-100, 100]), a fifth of them
// snapped onto a face edge, a cube corner or an axis; footprints of 2^[-3, 13]
// texels (or the bias alone: with_da false); levels up to max_level (-1: all).
CubeLookup random_cube(int size, std::int64_t C, std::int64_t N, CubeFilter filter, unsigned seed, bool with_da = true,
                       bool bias = false, int max_level = -1) {
  CubeLookup l = cube_base(size, C, filter, seed, max_level);
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::int64_t s = 0; s < N; ++s) {
    double d[3] = {normal(rng), normal(rng), normal(rng)};
    const int snap = int(unit(rng) * 25);
    if (snap == 0) d[1] = std::copysign(d[0], d[1]);  // |x| = |y|: the edge between an X and a Y face (or inside Z)
    if (snap == 1) d[1] = std::copysign(d[0], d[1]), d[2] = std::copysign(d[0], d[2]);  // a cube corner
    if (snap == 2) d[0] = d[1] = 0.0;                                                    // the Z axis
    if (snap == 3) d[2] = std::copysign(std::max(std::abs(d[0]), std::abs(d[1])), d[2]);  // a Z face's edge
    const double length = std::exp2(std::round(-100.0 + 200.0 * unit(rng)));
    for (double& x : d) x = double(float(x)) * length;  // exact in float: snapped edges stay exact
    add_sample(l, d, std::exp2(-3.0 + 16.0 * unit(rng)), int(unit(rng) * 6), rng);
  }
  if (!with_da) l.da.clear();
  finish(l, seed, bias);
  return l;
}

// Directions on a grid of components {-1, -1/2, -(S-1)/S..., 0, ...} scaled by
// 1, 2^-100 and 2^100: every face edge, cube corner and axis (and the zero
// vector), the texel centres and edges along them; footprints of exactly 2^k
// texels (the LOD an integer) along one axis.
CubeLookup hard_cube(int size, std::int64_t C, CubeFilter filter, unsigned seed) {
  CubeLookup l = cube_base(size, C, filter, seed);
  std::mt19937 rng(seed);
  std::vector<double> values{0.0, 1.0, 0.5, 1.0 / size, 1.0 - 1.0 / size, 1.0 - 0.5 / size, 0.5 / size};
  const std::size_t n = values.size();
  for (std::size_t i = 1; i < n; ++i) values.push_back(-values[i]);
  int k = 0;
  for (double scale : {1.0, std::exp2(-100.0), std::exp2(100.0)})
    for (double x : values)
      for (double y : values)
        for (double z : values) {
          const double d[3] = {double(float(x)) * scale, double(float(y)) * scale, double(float(z)) * scale};
          add_sample(l, d, std::exp2(k % 6 - 1), 2, rng);
          ++k;
        }
  finish(l, seed, false);
  return l;
}

struct Result {
  std::vector<float> out, faces, dir, da, bias;
};

// Forward and adjoint into fresh buffers, by the CPU kernel in T (on the float
// inputs converted) or by the device (gpu).
template <class T>
Result run(const CubeLookup& l, bool gpu) {
  auto as_t = [](const std::vector<float>& v) { return std::vector<T>(v.begin(), v.end()); };
  struct {
    std::vector<T> faces, pyramid, dir, da, bias;
  } in{as_t(l.faces), as_t(l.pyramid), as_t(l.dir), as_t(l.da), as_t(l.bias)};
  const CubeTextureParams<T> p = l.params_of<T>(in);
  const std::vector<T> grad_out = as_t(l.grad_out);
  std::vector<T> out(l.N * l.C, T(-7)), faces(l.faces.size()), dir(3 * l.N), da(6 * l.N), bias(l.N);
  CubeTextureGrads<T> g;
  g.faces = faces.data();
  g.dir = dir.data();
  g.dir_da = da.data();
  g.mip_level_bias = bias.data();
  if constexpr (std::is_same_v<T, float>) {
    if (gpu) {
      vulkan::cube_texture_forward(*shared_gpu(), p, out.data());
      vulkan::cube_texture_backward(*shared_gpu(), p, grad_out.data(), g);
    }
  }
  if (!gpu) {
    cube_texture_forward(p, out.data());
    cube_texture_backward(p, grad_out.data(), g);
  }
  auto as_float = [](const std::vector<T>& v) { return std::vector<float>(v.begin(), v.end()); };
  return {as_float(out), as_float(faces), as_float(dir), as_float(da), as_float(bias)};
}
Result on_gpu(const CubeLookup& l) { return run<float>(l, true); }

// Largest |gpu - cpu| / max(|cpu|, floor max|cpu|, 1e-30); equal values
// (infinities included) count 0, anything else not finite counts infinite.
double scaled_error(const std::vector<float>& gpu, const std::vector<float>& cpu, double floor = 1e-2) {
  double largest = 0.0, worst = 0.0;
  for (float x : cpu)
    if (std::isfinite(x)) largest = std::max(largest, double(std::abs(x)));
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    if (gpu[i] == cpu[i]) continue;
    const double e = std::abs(double(gpu[i]) - double(cpu[i])) /
                     std::max({double(std::abs(cpu[i])), floor * largest, 1e-30});
    worst = std::isfinite(e) ? std::max(worst, e) : std::numeric_limits<double>::infinity();
  }
  return worst;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

void check_gpu_matches_cpu(const CubeLookup& l) {
  INFO(l.describe());
  const Result cpu = run<float>(l, false), exact = run<double>(l, false), gpu = on_gpu(l);
  if (is_mipmapped(l.filter))
    CHECK(scaled_error(gpu.out, cpu.out, 1e-6) <= 1e-6);
  else
    CHECK(same_bits(gpu.out, cpu.out));
  const std::pair<const std::vector<float>*, const std::vector<float>*> grads[] = {
      {&gpu.faces, &exact.faces}, {&gpu.dir, &exact.dir}, {&gpu.da, &exact.da}, {&gpu.bias, &exact.bias}};
  for (const auto& [g, c] : grads) CHECK(scaled_error(*g, *c) <= 1e-5);
}

const CubeFilter kFilters[] = {CubeFilter::Nearest, CubeFilter::Bilinear, CubeFilter::LinearMipmapNearest,
                               CubeFilter::Trilinear};

}  // namespace

TEST_CASE("GPU cube-map lookups and gradients equal the CPU's for every filter on random directions", "[vulkan][cube]") {
  if (!shared_gpu()) return;
  unsigned seed = 300;
  for (CubeFilter f : kFilters) {
    check_gpu_matches_cpu(random_cube(16, 3, 3000, f, ++seed));
    check_gpu_matches_cpu(random_cube(5, 2, 1000, f, ++seed));  // odd: levels 5, 2, 1
    check_gpu_matches_cpu(random_cube(2, 1, 500, f, ++seed));
    check_gpu_matches_cpu(random_cube(1, 2, 300, f, ++seed));  // every tap across an edge or at a corner
  }
}

TEST_CASE("GPU mipmapped cube-map lookups with the LOD from the bias alone or with a bias on top, and fewer levels, "
          "equal the CPU's", "[vulkan][cube]") {
  if (!shared_gpu()) return;
  for (CubeFilter f : {CubeFilter::LinearMipmapNearest, CubeFilter::Trilinear}) {
    check_gpu_matches_cpu(random_cube(16, 3, 2000, f, 40, false, true));  // the bias is the LOD
    check_gpu_matches_cpu(random_cube(16, 3, 2000, f, 41, true, true));   // footprint + bias
    check_gpu_matches_cpu(random_cube(7, 1, 1000, f, 42, true, true));
    check_gpu_matches_cpu(random_cube(16, 2, 1000, f, 43, true, true, 2));  // max_mip_level 2: 16, 8, 4
    check_gpu_matches_cpu(random_cube(16, 2, 500, f, 44, true, false, 0));  // level 0 alone
  }
}

TEST_CASE("GPU cube-map lookups on face edges, cube corners, axes and texel centres equal the CPU's",
          "[vulkan][cube]") {
  if (!shared_gpu()) return;
  for (CubeFilter f : kFilters)
    for (int size : {1, 4, 5}) check_gpu_matches_cpu(hard_cube(size, 2, f, 50 + size));
}

TEST_CASE("GPU cube-map gradients are the same bits run after run and accumulate", "[vulkan][cube]") {
  if (!shared_gpu()) return;
  for (CubeFilter f : kFilters) {
    const CubeLookup l = random_cube(8, 3, 20000, f, 60 + int(f), true, true);
    const Result a = on_gpu(l), b = on_gpu(l);
    CHECK(same_bits(a.out, b.out));
    CHECK(same_bits(a.faces, b.faces));
    CHECK(same_bits(a.dir, b.dir));
    CHECK(same_bits(a.da, b.da));
    CHECK(same_bits(a.bias, b.bias));
    // += : a second adjoint into the same buffers doubles them.
    std::vector<float> faces = a.faces, dir = a.dir;
    CubeTextureGrads<float> g;
    g.faces = faces.data();
    g.dir = dir.data();
    vulkan::cube_texture_backward(*shared_gpu(), l.params(), l.grad_out.data(), g);
    for (std::size_t i = 0; i < faces.size(); ++i) REQUIRE(faces[i] == a.faces[i] + a.faces[i]);
    for (std::size_t i = 0; i < dir.size(); ++i) REQUIRE(dir[i] == a.dir[i] + a.dir[i]);
  }
}

TEST_CASE("the cube_texture op on a Vulkan backend gives the CPU op's samples and gradients", "[vulkan][cube]") {
  if (!shared_gpu()) return;
  for (CubeFilter f : kFilters) {
    INFO("filter " << int(f));
    CubeTextureOptions cpu_options, gpu_options;
    cpu_options.filter = gpu_options.filter = f;
    gpu_options.backend = vulkan::raster_backend(shared_gpu());
    std::vector<float> values[2][5];
    for (int gpu = 0; gpu < 2; ++gpu) {
      Tensor tex = Tensor::uniform({6, 9, 9, 3}, -1, 1, 3).set_requires_grad();
      Tensor dir = Tensor::uniform({20, 15, 3}, -1, 1, 4).set_requires_grad();
      Tensor da = Tensor::uniform({20, 15, 6}, -0.2, 0.2, 5).set_requires_grad();
      Tensor bias = Tensor::uniform({20, 15}, -1, 1, 6).set_requires_grad();
      const bool mip = is_mipmapped(f);
      Tensor out = mip ? cube_texture(tex, dir, gpu ? gpu_options : cpu_options, da, bias)
                       : cube_texture(tex, dir, gpu ? gpu_options : cpu_options);
      backward(sum(out * Tensor::uniform({20, 15, 3}, -1, 1, 8)));
      auto as_vector = [](const Tensor& t) {
        return t.defined() ? std::vector<float>(t.data<float>(), t.data<float>() + t.numel()) : std::vector<float>();
      };
      values[gpu][0] = as_vector(out);
      values[gpu][1] = as_vector(tex.grad());
      values[gpu][2] = as_vector(dir.grad());
      values[gpu][3] = mip ? as_vector(da.grad()) : std::vector<float>();
      values[gpu][4] = mip ? as_vector(bias.grad()) : std::vector<float>();
    }
    CHECK(scaled_error(values[1][0], values[0][0], 1e-6) <= 1e-6);
    for (int i = 1; i < 5; ++i) CHECK(scaled_error(values[1][i], values[0][i]) <= 1e-5);
  }
}

TEST_CASE("the cube_texture op on a Vulkan backend keeps float64 on the CPU and refuses bad input", "[vulkan][cube]") {
  if (!shared_gpu()) return;
  CubeTextureOptions gpu_options;
  gpu_options.backend = vulkan::raster_backend(shared_gpu());
  const Tensor tex64 = Tensor::uniform({6, 4, 4, 2}, -1, 1, 3, DType::Float64);
  const Tensor dir64 = Tensor::uniform({9, 3}, -1, 1, 4, DType::Float64);
  const Tensor a = cube_texture(tex64, dir64, gpu_options), b = cube_texture(tex64, dir64);
  CHECK(std::memcmp(a.data<double>(), b.data<double>(), a.numel() * sizeof(double)) == 0);
  // NaN in dir, a wrong dtype, a mipmapped filter without dir_da or bias: the op's errors.
  const Tensor tex = Tensor::uniform({6, 4, 4, 2}, -1, 1, 3);
  CHECK_THROWS_WITH(cube_texture(tex, Tensor::from_values({0.5, NAN, 1.0}, {1, 3}), gpu_options),
                    Catch::Contains("dir") && Catch::Contains("NaN"));
  CHECK_THROWS_AS(cube_texture(tex, dir64, gpu_options), DTypeError);
  gpu_options.filter = CubeFilter::Trilinear;
  CHECK_THROWS_AS(cube_texture(tex, Tensor::uniform({9, 3}, -1, 1, 4), gpu_options), ValueError);
  // The device's own checks (direct calls): NaN or Inf in dir_da, tex and the
  // bias, non-square faces.
  CubeLookup l = random_cube(8, 1, 10, CubeFilter::Trilinear, 5, true, true);
  std::vector<float> out(10);
  l.da[3] = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH(vulkan::cube_texture_forward(*shared_gpu(), l.params(), out.data()), Catch::Contains("dir_da"));
  l.da[3] = 0.f;
  l.bias[2] = NAN;
  CHECK_THROWS_WITH(vulkan::cube_texture_forward(*shared_gpu(), l.params(), out.data()),
                    Catch::Contains("mip_level_bias"));
  l.bias[2] = 0.f;
  l.faces[5] = NAN;
  CHECK_THROWS_WITH(vulkan::cube_texture_backward(*shared_gpu(), l.params(), l.grad_out.data(), {}),
                    Catch::Contains("tex"));
  l.faces[5] = 0.f;
  // No pyramid: the device builds cube_mip_build's levels (test_vulkan_cube_texture_resident.cpp compares more).
  cube_mip_build(l.faces.data(), l.C, l.layout, l.pyramid.data());
  std::vector<float> with_levels(10);
  vulkan::cube_texture_forward(*shared_gpu(), l.params(), with_levels.data());
  l.pyramid.clear();
  CHECK_NOTHROW(vulkan::cube_texture_forward(*shared_gpu(), l.params(), out.data()));
  CHECK(out == with_levels);
  l = random_cube(8, 1, 10, CubeFilter::Bilinear, 5);
  l.layout = mip_layout(8, 4, 0);
  CHECK_THROWS_AS(vulkan::cube_texture_forward(*shared_gpu(), l.params(), out.data()), ShapeError);
}
