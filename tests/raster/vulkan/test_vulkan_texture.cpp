// The GPU's texture lookups and their adjoint (raster/vulkan/texture.h)
// against the CPU kernels (raster/texture.h) on the same inputs: every filter,
// wrap mode and LOD rule, odd and non-power-of-two sizes, uv far outside
// [0, 1] and exactly on texel centres and edges, zero, equal and huge uv
// derivatives, a bias, the user's mip levels, a 2048 x 2048 texture with its
// full mip chain; the texture op on a Vulkan backend; the same bits run after
// run; accumulation (+=); bad input.
//
// Samples: each within 1e-6 of the CPU's relative to itself (bit for bit for
// nearest and bilinear). Gradients: each within 1e-5 relative to itself, with
// an absolute floor of 1e-2 of the tensor's largest (and 1e-9: the inputs
// are of order 1, so smaller values are the rounding of cancelled sums):
//   |gpu - cpu| <= 1e-5 max(|cpu|, 1e-2 max |cpu|, 1e-9),
// against the CPU kernel run in float64 on the same (float32) inputs: the
// float32 kernel sums the texels' gradients in float where it reads no mip
// level (400 contributions to a 1 x 1 texture leave it 2.6e-5 off), the GPU
// in fixed point, exactly to 2^-59 x samples x the largest contribution.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <random>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/base/error.h"
#include "ops/ops.h"
#include "raster/mipmap.h"
#include "raster/texture.h"
#include "raster/vulkan/backend.h"
#include "raster/vulkan/scenes.h"
#include "raster/vulkan/texture.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

// One texture call's host inputs.
struct Lookup {
  int H = 0, W = 0;
  std::int64_t C = 1, S = 0;
  std::vector<float> tex, pyramid, uv, dx, dy, bias, grad_out;
  MipLayout layout;
  Filter filter = Filter::Bilinear;
  Wrap wrap = Wrap::Repeat;
  LodRule lod_rule = LodRule::Isotropic;
  bool v_down = false, user_pyramid = false;

  // The kernels' view of the arrays `a` (this lookup's, or copies in another type).
  template <class T, class Arrays>
  TextureParams<T> params_of(const Arrays& a) const {
    TextureParams<T> p;
    p.tex = a.tex.data();
    p.pyramid = a.pyramid.empty() ? nullptr : a.pyramid.data();
    p.user_pyramid = user_pyramid;
    p.layout = layout;
    p.channels = C;
    p.uv = a.uv.data();
    p.uv_dx = a.dx.empty() ? nullptr : a.dx.data();
    p.uv_dy = a.dy.empty() ? nullptr : a.dy.data();
    p.mip_level_bias = a.bias.empty() ? nullptr : a.bias.data();
    p.num_samples = S;
    p.filter = filter;
    p.wrap = wrap;
    p.lod_rule = lod_rule;
    p.v_down = v_down;
    return p;
  }
  TextureParams<float> params() const { return params_of<float>(*this); }
  std::string describe() const {
    std::ostringstream o;
    o << H << "x" << W << "x" << C << ", " << S << " samples, filter " << int(filter) << ", wrap " << int(wrap)
      << ", lod rule " << int(lod_rule) << (v_down ? ", v_down" : "") << (user_pyramid ? ", user's levels" : "")
      << (bias.empty() ? "" : ", bias");
    return o.str();
  }
};

// A random H x W x C texture with S samples: uv in [lo, hi), derivatives of
// magnitude 2^[-3, 3] texels up to 2^[-3, 13] (every level and beyond; some
// zero, some equal in x and y, some exact powers of two), random incoming
// gradients (some samples' all zero).
Lookup random_lookup(int H, int W, std::int64_t C, std::int64_t S, Filter filter, Wrap wrap, unsigned seed,
                     double lo = -2.5, double hi = 3.5) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0), coord(lo, hi), sign(-1.0, 1.0);
  Lookup l;
  l.H = H, l.W = W, l.C = C, l.S = S, l.filter = filter, l.wrap = wrap;
  l.tex = random_values(std::size_t(H) * W * C, seed + 1);
  l.layout = mip_layout(H, W, mipmapped(filter) ? -1 : 0);
  if (l.layout.count() > 1) {
    l.pyramid.resize((l.layout.total_texels - std::int64_t(H) * W) * C);
    mip_build(l.tex.data(), C, l.layout, l.pyramid.data());
  }
  for (std::int64_t s = 0; s < S; ++s) {
    l.uv.push_back(float(coord(rng)));
    l.uv.push_back(float(coord(rng)));
  }
  if (mipmapped(filter)) {
    for (std::int64_t s = 0; s < S; ++s) {
      const int kind = int(unit(rng) * 8);
      const double scale = std::exp2(-3.0 + 16.0 * unit(rng));
      float d[4];
      for (float& x : d) x = float(scale * sign(rng) / std::max(H, W));
      if (kind == 0) d[0] = d[1] = d[2] = d[3] = 0.f;                 // no footprint
      if (kind == 1) d[2] = d[0], d[3] = d[1];                        // a = b
      if (kind == 2) d[0] = float(std::exp2(std::round(std::log2(scale))) / W), d[1] = d[2] = d[3] = 0.f;  // 2^k texels
      if (kind == 3) d[2] = -d[1] * W / H, d[3] = d[0] * H / W;       // a perpendicular to b, equal lengths
      l.dx.insert(l.dx.end(), {d[0], d[1]});
      l.dy.insert(l.dy.end(), {d[2], d[3]});
    }
  }
  l.grad_out = random_values(std::size_t(S) * C, seed + 2);
  for (std::int64_t s = 0; s < S; s += 7)
    for (std::int64_t c = 0; c < C; ++c) l.grad_out[s * C + c] = 0.f;
  return l;
}

struct Result {
  std::vector<float> out, tex, uv, dx, dy, bias, pyramid;
};

// Forward and adjoint into fresh buffers, by the CPU kernels in T (on the
// float inputs converted) or by the device (gpu).
template <class T>
Result run(const Lookup& l, bool gpu) {
  auto as_t = [](const std::vector<float>& v) { return std::vector<T>(v.begin(), v.end()); };
  struct {
    std::vector<T> tex, pyramid, uv, dx, dy, bias;
  } in{as_t(l.tex), as_t(l.pyramid), as_t(l.uv), as_t(l.dx), as_t(l.dy), as_t(l.bias)};
  const TextureParams<T> p = l.params_of<T>(in);
  const std::vector<T> grad_out = as_t(l.grad_out);
  std::vector<T> out(l.S * l.C, T(-7)), tex(l.tex.size()), uv(2 * l.S), dx(2 * l.S), dy(2 * l.S), bias(l.S),
      pyramid(l.pyramid.size());
  TextureGrads<T> g;
  g.tex = tex.data();
  g.uv = uv.data();
  g.uv_dx = dx.data();
  g.uv_dy = dy.data();
  g.mip_level_bias = bias.data();
  g.pyramid = pyramid.empty() ? nullptr : pyramid.data();
  if constexpr (std::is_same_v<T, float>) {
    if (gpu) {
      vulkan::texture_forward(*shared_gpu(), p, out.data());
      vulkan::texture_backward(*shared_gpu(), p, grad_out.data(), g);
    }
  }
  if (!gpu) {
    texture_forward(p, out.data());
    texture_backward(p, grad_out.data(), g);
  }
  auto as_float = [](const std::vector<T>& v) { return std::vector<float>(v.begin(), v.end()); };
  return {as_float(out), as_float(tex), as_float(uv), as_float(dx), as_float(dy), as_float(bias), as_float(pyramid)};
}
Result on_gpu(const Lookup& l) { return run<float>(l, true); }

// Largest |gpu - cpu| / max(|cpu|, floor max|cpu|, 1e-9) (the header's measure).
double scaled_error(const std::vector<float>& gpu, const std::vector<float>& cpu, double floor = 1e-2) {
  double largest = 0.0, worst = 0.0;
  for (float x : cpu) largest = std::max(largest, double(std::abs(x)));
  for (std::size_t i = 0; i < cpu.size(); ++i) {
    const double d = std::abs(double(gpu[i]) - double(cpu[i]));
    worst = std::max(worst, d / std::max({double(std::abs(cpu[i])), floor * largest, 1e-9}));
  }
  return worst;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// The GPU's results against the CPU's (the header's measures): samples
// against the float32 kernel's, gradients against the kernel's in float64 on
// the same inputs.
void check_gpu_matches_cpu(const Lookup& l) {
  INFO(l.describe());
  const Result cpu = run<float>(l, false), exact = run<double>(l, false), gpu = on_gpu(l);
  if (mipmapped(l.filter))
    CHECK(scaled_error(gpu.out, cpu.out, 1e-6) <= 1e-6);
  else
    CHECK(same_bits(gpu.out, cpu.out));
  CHECK(scaled_error(gpu.tex, exact.tex) <= 1e-5);
  CHECK(scaled_error(gpu.uv, exact.uv) <= 1e-5);
  CHECK(scaled_error(gpu.dx, exact.dx) <= 1e-5);
  CHECK(scaled_error(gpu.dy, exact.dy) <= 1e-5);
  CHECK(scaled_error(gpu.bias, exact.bias) <= 1e-5);
  CHECK(scaled_error(gpu.pyramid, exact.pyramid) <= 1e-5);
}

const Filter kFilters[] = {Filter::Nearest, Filter::Bilinear, Filter::Trilinear, Filter::LinearMipmapNearest};
const Wrap kWraps[] = {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Zero};

}  // namespace

TEST_CASE("GPU texture lookups and gradients equal the CPU's for every filter and wrap mode", "[vulkan]") {
  if (!shared_gpu()) return;
  unsigned seed = 100;
  for (Filter f : kFilters)
    for (Wrap w : kWraps) {
      check_gpu_matches_cpu(random_lookup(23, 37, 3, 3000, f, w, ++seed));  // odd, not powers of two
      check_gpu_matches_cpu(random_lookup(1, 5, 1, 400, f, w, ++seed));     // a row
      check_gpu_matches_cpu(random_lookup(1, 1, 2, 100, f, w, ++seed));     // one texel
      Lookup far = random_lookup(16, 9, 2, 1000, f, w, ++seed, -1000.0, 1000.0);  // uv far outside [0, 1]
      far.v_down = true;
      check_gpu_matches_cpu(far);
    }
}

TEST_CASE("GPU texture lookups exactly on texel centres and edges equal the CPU's", "[vulkan]") {
  if (!shared_gpu()) return;
  for (Filter f : kFilters)
    for (Wrap w : kWraps) {
      Lookup l = random_lookup(6, 10, 2, 0, f, w, 7);
      // u, v on every centre and edge of level 0 (and so of the coarser levels' edges), two periods out.
      for (int i = -12; i <= 24; ++i)
        for (int j = -8; j <= 14; ++j) {
          l.uv.push_back(float(0.5 * i / l.W));
          l.uv.push_back(float(0.5 * j / l.H));
          // A footprint of exactly 2^k texels: the LOD an integer.
          const float d = float(std::exp2((i + 12) % 5 - 1) / l.W);
          l.dx.insert(l.dx.end(), {d, 0.f});
          l.dy.insert(l.dy.end(), {0.f, 0.f});
        }
      l.S = static_cast<std::int64_t>(l.uv.size() / 2);
      if (!mipmapped(f)) l.dx.clear(), l.dy.clear();
      l.grad_out = random_values(std::size_t(l.S) * l.C, 8);
      check_gpu_matches_cpu(l);
    }
}

TEST_CASE("GPU trilinear lookups with either LOD rule, a bias and the user's levels equal the CPU's", "[vulkan]") {
  if (!shared_gpu()) return;
  for (Filter f : {Filter::Trilinear, Filter::LinearMipmapNearest})
    for (LodRule rule : {LodRule::Isotropic, LodRule::MajorAxis})
      for (int variant = 0; variant < 3; ++variant) {
        Lookup l = random_lookup(45, 30, 3, 2000, f, Wrap::Repeat, 40 + variant);
        l.lod_rule = rule;
        if (variant >= 1) {  // a bias per sample that moves the LOD across levels and past both ends
          l.bias = random_values(std::size_t(l.S), 41);
          for (float& b : l.bias) b *= 4.f;
        }
        if (variant == 2) {  // the user's own levels: their gradients stay on them
          l.user_pyramid = true;
          l.pyramid = random_values(l.pyramid.size(), 42);
        }
        check_gpu_matches_cpu(l);
      }
}

TEST_CASE("GPU trilinear lookups of a 2048 x 2048 texture with its full mip chain equal the CPU's", "[vulkan]") {
  if (!shared_gpu()) return;
  // 512 x 512 samples across the texture, footprints over every level.
  Lookup l = random_lookup(2048, 2048, 3, 512 * 512, Filter::Trilinear, Wrap::Repeat, 9, -0.2, 1.2);
  REQUIRE(l.layout.count() == 12);
  check_gpu_matches_cpu(l);
}

TEST_CASE("GPU texture gradients are the same bits run after run and accumulate", "[vulkan]") {
  if (!shared_gpu()) return;
  for (Filter f : kFilters) {
    const Lookup l = random_lookup(33, 20, 3, 20000, f, Wrap::Mirror, 60 + int(f), -0.3, 1.3);
    const Result a = on_gpu(l), b = on_gpu(l);
    CHECK(same_bits(a.out, b.out));
    CHECK(same_bits(a.tex, b.tex));
    CHECK(same_bits(a.uv, b.uv));
    CHECK(same_bits(a.dx, b.dx));
    CHECK(same_bits(a.bias, b.bias));
    // += : a second adjoint into the same buffers doubles them.
    std::vector<float> tex = a.tex, uv = a.uv;
    TextureGrads<float> g;
    g.tex = tex.data();
    g.uv = uv.data();
    vulkan::texture_backward(*shared_gpu(), l.params(), l.grad_out.data(), g);
    for (std::size_t i = 0; i < tex.size(); ++i) REQUIRE(tex[i] == a.tex[i] + a.tex[i]);
    for (std::size_t i = 0; i < uv.size(); ++i) REQUIRE(uv[i] == a.uv[i] + a.uv[i]);
  }
}

TEST_CASE("GPU texture gradients agree with float32 finite differences of the GPU's own lookups", "[vulkan]") {
  if (!shared_gpu()) return;
  // L = sum g . out; dL/dtexel by central differences of the GPU forward
  // (linear in the texels, so exact up to float rounding), checked on a few texels.
  Lookup l = random_lookup(8, 12, 2, 500, Filter::Trilinear, Wrap::Clamp, 71, -0.2, 1.2);
  const Result r = on_gpu(l);
  auto loss = [&](const Lookup& x) {
    std::vector<float> out(x.S * x.C);
    vulkan::texture_forward(*shared_gpu(), x.params(), out.data());
    double sum = 0.0;
    for (std::size_t i = 0; i < out.size(); ++i) sum += double(out[i]) * x.grad_out[i];
    return sum;
  };
  for (std::size_t i : {0, 5, 37, 101, 190}) {
    Lookup plus = l, minus = l;
    plus.tex[i] += 0.25f;
    minus.tex[i] -= 0.25f;
    for (Lookup* x : {&plus, &minus}) mip_build(x->tex.data(), x->C, x->layout, x->pyramid.data());
    const double fd = (loss(plus) - loss(minus)) / 0.5;
    CHECK(std::abs(fd - r.tex[i]) <= 1e-4 * (1.0 + std::abs(fd)));
  }
}

TEST_CASE("the texture op on a Vulkan backend gives the CPU op's samples and gradients", "[vulkan]") {
  if (!shared_gpu()) return;
  TextureOptions cpu_options, gpu_options;
  cpu_options.filter = gpu_options.filter = Filter::Trilinear;
  cpu_options.wrap = gpu_options.wrap = Wrap::Mirror;
  gpu_options.backend = vulkan::raster_backend(shared_gpu());
  // Two images with a texture each, then one texture shared by both.
  for (std::int64_t textures : {2, 1}) {
    std::vector<Tensor> grads[2];
    Tensor outs[2];
    for (int gpu = 0; gpu < 2; ++gpu) {
      Tensor tex = Tensor::uniform({textures, 19, 26, 3}, -1, 1, 3).set_requires_grad();
      Tensor uv = Tensor::uniform({2, 30, 20, 2}, -0.5, 1.5, 4).set_requires_grad();
      Tensor dx = Tensor::uniform({2, 30, 20, 2}, -0.2, 0.2, 5).set_requires_grad();
      Tensor dy = Tensor::uniform({2, 30, 20, 2}, -0.2, 0.2, 6).set_requires_grad();
      Tensor bias = Tensor::uniform({2, 30, 20}, -1, 1, 7).set_requires_grad();
      outs[gpu] = texture(tex, uv, gpu ? gpu_options : cpu_options, dx, dy, bias);
      backward(sum(outs[gpu] * Tensor::uniform({2, 30, 20, 3}, -1, 1, 8)));
      grads[gpu] = {tex.grad(), uv.grad(), dx.grad(), dy.grad(), bias.grad()};
    }
    auto values = [](const Tensor& t) { return std::vector<float>(t.data<float>(), t.data<float>() + t.numel()); };
    CHECK(scaled_error(values(outs[1]), values(outs[0]), 1e-6) <= 1e-6);
    for (int i = 0; i < 5; ++i) CHECK(scaled_error(values(grads[1][i]), values(grads[0][i])) <= 1e-5);
  }
  // Bilinear (the CPU keeps the forward's uv Jacobian; the device does not).
  gpu_options.filter = cpu_options.filter = Filter::Bilinear;
  std::vector<float> g[2];
  for (int gpu = 0; gpu < 2; ++gpu) {
    Tensor tex = Tensor::uniform({17, 11, 2}, -1, 1, 3);
    Tensor uv = Tensor::uniform({40, 2}, -0.5, 1.5, 4).set_requires_grad();
    backward(sum(pow(texture(tex, uv, gpu ? gpu_options : cpu_options), 2.0)));
    g[gpu].assign(uv.grad().data<float>(), uv.grad().data<float>() + uv.numel());
  }
  CHECK(scaled_error(g[1], g[0]) <= 1e-5);
}

TEST_CASE("the texture op on a Vulkan backend keeps float64 on the CPU and refuses bad input", "[vulkan]") {
  if (!shared_gpu()) return;
  TextureOptions gpu_options;
  gpu_options.backend = vulkan::raster_backend(shared_gpu());
  const Tensor tex64 = Tensor::uniform({5, 6, 2}, -1, 1, 3, DType::Float64);
  const Tensor uv64 = Tensor::uniform({9, 2}, -1, 2, 4, DType::Float64);
  const Tensor a = texture(tex64, uv64, gpu_options), b = texture(tex64, uv64);
  CHECK(std::memcmp(a.data<double>(), b.data<double>(), a.numel() * sizeof(double)) == 0);
  // NaN in uv, a wrong dtype, trilinear without derivatives: the op's errors, before the device.
  const Tensor tex = Tensor::uniform({5, 6, 2}, -1, 1, 3);
  CHECK_THROWS_WITH(texture(tex, Tensor::from_values({0.5, NAN}, {1, 2}), gpu_options),
                    Catch::Contains("uv") && Catch::Contains("NaN"));
  CHECK_THROWS_AS(texture(tex, uv64, gpu_options), DTypeError);
  gpu_options.filter = Filter::Trilinear;
  CHECK_THROWS_AS(texture(tex, Tensor::uniform({9, 2}, -1, 2, 4), gpu_options), ValueError);
  // The device's own checks (direct calls): NaN in uv_dx, the user's pyramid
  // missing (a missing built one is built on the device: the same samples).
  Lookup l = random_lookup(8, 8, 1, 10, Filter::Trilinear, Wrap::Repeat, 5);
  l.dx[3] = NAN;
  std::vector<float> out(10), built(10);
  CHECK_THROWS_WITH(vulkan::texture_forward(*shared_gpu(), l.params(), out.data()), Catch::Contains("uv_dx"));
  l.dx[3] = 0.f;
  vulkan::texture_forward(*shared_gpu(), l.params(), out.data());
  l.pyramid.clear();
  vulkan::texture_forward(*shared_gpu(), l.params(), built.data());
  CHECK(built == out);
  l.user_pyramid = true;
  CHECK_THROWS_WITH(vulkan::texture_forward(*shared_gpu(), l.params(), out.data()), Catch::Contains("pyramid"));
}
