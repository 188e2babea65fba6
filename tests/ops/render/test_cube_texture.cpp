// Tests of the cube_texture op: float64 gradchecks w.r.t. texels, direction,
// direction derivatives and LOD bias for every filter, on random directions
// and on hard cases (taps off a face edge, the 8 cube corners from each of
// their 3 faces, LODs just either side of a level), nearest and zero-direction
// behaviour, float32 against float64, determinism for 1, 2 and 8 threads, and
// bad arguments.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/render/cube_texture.h"
#include "ops/tensor/elementwise.h"
#include "ops/tensor/reduce.h"
#include "raster/cube_map.h"
#include "raster/mipmap.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

double to_integer(double x) { return std::abs(x - std::round(x)); }

// True if (s, t) is `margin` texels clear of every bilinear cell boundary of
// levels [first, last], and the direction is clear of the face boundary, so
// gradcheck's +-2 eps steps stay on one smooth piece.
bool clear_of_cells(const raster::CubeProjection& p, const raster::MipLayout& layout, int first, int last,
                    double margin = 0.05) {
  if (p.face < 0 || std::abs(p.sc) > (1 - 1e-3) * p.q || std::abs(p.tc) > (1 - 1e-3) * p.q) return false;
  for (int l = first; l <= last && l < layout.count(); ++l) {
    const int n = layout.levels[l].width;
    if (to_integer(p.s * n - 0.5) < margin || to_integer(p.t * n - 0.5) < margin) return false;
  }
  return true;
}

// Directions for a face size S, each clear of the cells of levels [first, last]:
// `random` uniform ones of lengths 0.5..2, then, if `hard`, some whose taps
// fall off a face edge (within half a texel of it) and 24 by the 8 cube
// corners (each corner from each of its 3 faces, within half a texel of both edges).
std::vector<double> sample_dirs(int S, int random, bool hard, const raster::MipLayout& layout, int first, int last,
                                unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), len(0.5, 2), near(0.002, 0.98 / S);
  std::vector<double> dirs;
  auto push_if_clear = [&](const std::array<double, 3>& d) {
    if (!clear_of_cells(raster::cube_project(d[0], d[1], d[2]), layout, first, last)) return false;
    dirs.insert(dirs.end(), d.begin(), d.end());
    return true;
  };
  for (int i = 0; i < random;) i += push_if_clear({u(rng), u(rng), u(rng)});
  if (!hard) return dirs;
  // Off one edge: the major axis at +-q, one other axis within half a texel of +-q.
  for (int i = 0; i < 12;) {
    const int major = i % 3, edge = (major + 1 + (i / 3) % 2) % 3, free = 3 - major - edge;
    const double q = len(rng), sm = i % 2 ? 1 : -1, se = (i / 2) % 2 ? 1 : -1;
    std::array<double, 3> d{};
    d[major] = sm * q, d[edge] = se * (1 - near(rng)) * q, d[free] = 0.9 * u(rng) * q;
    i += push_if_clear(d);
  }
  // The 8 corners, from each face that meets there.
  for (int corner = 0; corner < 8; ++corner)
    for (int major = 0; major < 3; ++major)
      for (;;) {
        const double q = len(rng);
        std::array<double, 3> d{};
        for (int k = 0; k < 3; ++k) {
          const double sign = (corner >> k) & 1 ? 1 : -1;
          d[k] = sign * (k == major ? 1 : 1 - near(rng)) * q;
        }
        if (push_if_clear(d)) break;
      }
  return dirs;
}

Tensor dirs_tensor(const std::vector<double>& d) {
  return Tensor::from_values(d, {static_cast<std::int64_t>(d.size() / 3), 3}, DType::Float64);
}

// Screen derivatives dir_da giving each sample a footprint of major axis
// 2^lod face texels (minor 0.2..0.6 of it, random orientation) for faces of
// size S, plus a random radial part (which leaves s, t unchanged).
Tensor derivatives_for(const std::vector<double>& dirs, const std::vector<double>& lods, int S, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0, 6.283), minor(0.2, 0.6), radial(-0.3, 0.3);
  std::vector<double> da;
  for (std::size_t i = 0; i < lods.size(); ++i) {
    const raster::CubeProjection p = raster::cube_project(dirs[3 * i], dirs[3 * i + 1], dirs[3 * i + 2]);
    const raster::CubeFace& f = raster::kCubeFaces[p.face];
    // J = R(a) diag(major, minor) R(b): columns (sX, tX), (sY, tY) in texels.
    const double a = angle(rng), b = angle(rng), s1 = std::pow(2.0, lods[i]), s2 = s1 * minor(rng);
    const double ca = std::cos(a), sa = std::sin(a), cb = std::cos(b), sb = std::sin(b);
    const double J[2][2] = {{ca * s1 * cb - sa * s2 * sb, -ca * s1 * sb - sa * s2 * cb},
                            {sa * s1 * cb + ca * s2 * sb, -sa * s1 * sb + ca * s2 * cb}};
    double d[2][3];  // d(dir)/dX, d(dir)/dY
    for (int col = 0; col < 2; ++col) {
      // d(dir) = (sX / S) 2q s_sign e_s + (tX / S) 2q t_sign e_t + rho dir.
      const double rho = radial(rng);
      for (int k = 0; k < 3; ++k) d[col][k] = rho * dirs[3 * i + k];
      d[col][f.s_axis] += J[0][col] / S * 2 * p.q * f.s_sign;
      d[col][f.t_axis] += J[1][col] / S * 2 * p.q * f.t_sign;
    }
    for (int k = 0; k < 3; ++k) da.insert(da.end(), {d[0][k], d[1][k]});
  }
  return Tensor::from_values(da, {static_cast<std::int64_t>(lods.size()), 6}, DType::Float64);
}

CubeTextureOptions with(CubeFilter f, int max_mip_level = -1) {
  CubeTextureOptions o;
  o.filter = f;
  o.max_mip_level = max_mip_level;
  return o;
}

}  // namespace

TEST_CASE("cube_texture: bilinear gradients w.r.t. texels and direction match finite differences, edges and corners included",
          "[ops][cube][gradcheck]") {
  const int S = 6;
  const raster::MipLayout layout = raster::mip_layout(S, S, 0);
  const std::vector<double> d = sample_dirs(S, 24, true, layout, 0, 0, 1);
  Tensor tex = random_input({6, S, S, 3}, -1, 1, 2);
  Tensor dir = dirs_tensor(d).set_requires_grad();
  REQUIRE(dir.size(0) == 24 + 12 + 24);
  require_gradcheck("cube_texture bilinear: tex, dir",
                    [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Bilinear)); }, {tex, dir});
  SECTION("2e-3 from the face switch, on each side of all 12 edges") {
    // Both faces at an edge, the direction 0.998 |ma| along the edge's other axis.
    std::vector<double> e;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int sign = 0; sign < 4 && i != j; ++sign) {
          std::array<double, 3> d{};
          d[i] = sign & 1 ? 1.3 : -1.3;
          d[j] = (sign & 2 ? 1 : -1) * 0.998 * 1.3;
          d[3 - i - j] = 0.37 - 0.1 * sign;
          REQUIRE(clear_of_cells(raster::cube_project(d[0], d[1], d[2]), layout, 0, 0));
          e.insert(e.end(), d.begin(), d.end());
        }
    Tensor dir_e = dirs_tensor(e).set_requires_grad();
    REQUIRE(dir_e.size(0) == 24);
    require_gradcheck("cube_texture bilinear 2e-3 from every edge: tex, dir",
                      [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Bilinear)); },
                      {tex, dir_e});
  }
  SECTION("on 1 x 1 faces every lookup is a corner lookup") {
    const raster::MipLayout one = raster::mip_layout(1, 1);
    Tensor tex1 = random_input({6, 1, 1, 2}, -1, 1, 3);
    Tensor dir1 = dirs_tensor(sample_dirs(1, 20, false, one, 0, 0, 4)).set_requires_grad();
    require_gradcheck("cube_texture bilinear 1x1: tex, dir",
                      [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Bilinear)); },
                      {tex1, dir1});
  }
}

TEST_CASE("cube_texture: trilinear gradients w.r.t. texels, direction, dir_da and bias match finite differences",
          "[ops][cube][gradcheck]") {
  // 8 -> 4 -> 2 -> 1: LODs inside levels 0..2 (fractions 0.15..0.85), some
  // shifted by a bias; every sample clear of the cells of both levels it reads.
  const int S = 8;
  const raster::MipLayout layout = raster::mip_layout(S, S);
  REQUIRE(layout.count() == 4);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> frac(0.15, 0.85);
  std::vector<double> dirs, lods, biases;
  for (int level = 0; level < 3; ++level) {
    const std::vector<double> d = sample_dirs(S, 8, true, layout, level, level + 1, 10 + level);
    dirs.insert(dirs.end(), d.begin(), d.end());
    for (std::size_t i = 0; i < d.size() / 3; ++i) {
      const double bias = i % 3 == 1 ? 0.4 : i % 3 == 2 ? -0.3 : 0.0;
      lods.push_back(level + frac(rng) - bias);
      biases.push_back(bias);
    }
  }
  const std::int64_t n = static_cast<std::int64_t>(lods.size());
  Tensor tex = random_input({6, S, S, 2}, -1, 1, 6);
  Tensor dir = dirs_tensor(dirs).set_requires_grad();
  Tensor da = derivatives_for(dirs, lods, S, 7).set_requires_grad();
  Tensor bias = Tensor::from_values(biases, {n}, DType::Float64).set_requires_grad();
  require_gradcheck("cube_texture trilinear: tex, dir, dir_da, bias",
                    [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Trilinear), in[2], in[3]); },
                    {tex, dir, da, bias});
  // The LOD path carries gradient (a constant texture would make it zero).
  backward(sum(cube_texture(tex, dir, with(CubeFilter::Trilinear), da, bias)));
  double largest = 0;
  for (double g : bias.grad().to_vector()) largest = std::max(largest, std::abs(g));
  CHECK(largest > 1e-3);

  SECTION("with the LOD from the bias alone") {
    std::vector<double> sum_lod(lods);
    for (std::size_t i = 0; i < sum_lod.size(); ++i) sum_lod[i] += biases[i];
    Tensor total = Tensor::from_values(sum_lod, {n}, DType::Float64).set_requires_grad();
    require_gradcheck("cube_texture trilinear bias only: tex, dir, bias",
                      [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Trilinear), {}, in[2]); },
                      {tex, dir, total});
  }
  SECTION("linear-mipmap-nearest: texels and direction; no gradient through the LOD") {
    require_gradcheck("cube_texture linear-mipmap-nearest: tex, dir, dir_da, bias",
                      [&](const Inputs& in) {
                        return cube_texture(in[0], in[1], with(CubeFilter::LinearMipmapNearest), in[2], in[3]);
                      },
                      {tex, dir, da, bias});
  }
}

TEST_CASE("cube_texture: gradients match finite differences just either side of every level transition and where clamped",
          "[ops][cube][gradcheck]") {
  // 16 -> 8 -> 4 -> 2 -> 1. LODs k +- 0.01 (the blend weight f near 0 and 1),
  // 0.01 (just above magnification), 3.99, and clamped ones (-0.7, 5.2) whose
  // LOD gradients are 0.
  const int S = 16;
  const raster::MipLayout layout = raster::mip_layout(S, S);
  const std::vector<double> targets = {0.01, 0.99, 1.01, 1.99, 2.01, 2.99, 3.01, 3.99, -0.7, 5.2};
  std::vector<double> dirs, lods;
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const double lod = targets[i];
    const int l0 = std::max(0, std::min(3, static_cast<int>(std::floor(lod))));
    const std::vector<double> d = sample_dirs(S, 2, false, layout, l0, l0 + 1, 20 + unsigned(i));
    dirs.insert(dirs.end(), d.begin(), d.end());
    lods.insert(lods.end(), {lod, lod});
  }
  Tensor tex = random_input({6, S, S, 1}, -1, 1, 8);
  Tensor dir = dirs_tensor(dirs).set_requires_grad();
  Tensor da = derivatives_for(dirs, lods, S, 9).set_requires_grad();
  require_gradcheck("cube_texture trilinear level transitions: tex, dir, dir_da",
                    [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Trilinear), in[2]); },
                    {tex, dir, da});
  // Clamped LODs (the last 4 samples): no gradient to dir_da.
  backward(sum(cube_texture(tex, dir, with(CubeFilter::Trilinear), da)));
  const std::vector<double> g = da.grad().to_vector();
  for (std::size_t k = g.size() - 4 * 6; k < g.size(); ++k) CHECK(g[k] == 0.0);
  SECTION("max_mip_level stops the chain: LODs beyond it are clamped there") {
    Tensor tex2 = random_input({6, S, S, 1}, -1, 1, 10);
    require_gradcheck("cube_texture trilinear max_mip_level 2: tex, dir",
                      [&](const Inputs& in) { return cube_texture(in[0], in[1], with(CubeFilter::Trilinear, 2), da); },
                      {tex2, dir});
  }
}

TEST_CASE("cube_texture: nearest returns the hit texel, sends its gradient only there and none to the direction",
          "[ops][cube]") {
  const int S = 2;
  std::vector<double> t;
  for (int k = 0; k < 6 * S * S; ++k) t.push_back(k);
  Tensor tex = Tensor::from_values(t, {6, S, S, 1}, DType::Float64).set_requires_grad();
  // -Y face (3): sc = x, tc = -z. (0.5, -1, 0.5): s = 0.75, t = 0.25 -> row 0, column 1: texel 3*4 + 1.
  // +Z face (4): (-0.2, -0.6, 1): sc = -0.2, tc = 0.6 -> s = 0.4, t = 0.8 -> row 1, column 0: texel 4*4 + 2.
  Tensor dir = Tensor::from_values({0.5, -1, 0.5, -0.2, -0.6, 1}, {2, 3}, DType::Float64).set_requires_grad();
  Tensor out = cube_texture(tex, dir, with(CubeFilter::Nearest));
  REQUIRE(out.shape() == Shape{2, 1});
  CHECK(out.at({0, 0}) == 13);
  CHECK(out.at({1, 0}) == 18);
  backward(out, Tensor::from_values({2, 3}, {2, 1}, DType::Float64));
  std::vector<double> want(6 * S * S, 0.0);
  want[13] = 2, want[18] = 3;
  CHECK(tex.grad().to_vector() == want);
  CHECK(dir.grad().to_vector() == std::vector<double>(6, 0.0));
}

TEST_CASE("cube_texture: the zero direction samples 0 and passes no gradient", "[ops][cube]") {
  Tensor tex = Tensor::uniform({6, 4, 4, 2}, 0.5, 1, 11, DType::Float64).set_requires_grad();
  Tensor dir = Tensor::from_values({0, 0, 0, 0.3, -0.2, 0.9}, {2, 3}, DType::Float64).set_requires_grad();
  Tensor da = Tensor::full({2, 6}, 0.05, DType::Float64).set_requires_grad();
  Tensor bias = Tensor::full({2}, 0.5, DType::Float64).set_requires_grad();
  for (CubeFilter f : {CubeFilter::Nearest, CubeFilter::Bilinear, CubeFilter::LinearMipmapNearest, CubeFilter::Trilinear}) {
    const bool mip = raster::is_mipmapped(f);
    Tensor out = cube_texture(tex, dir, with(f), mip ? da : Tensor(), mip ? bias : Tensor());
    CHECK(out.at({0, 0}) == 0);
    CHECK(out.at({0, 1}) == 0);
    CHECK(out.at({1, 0}) > 0);
    // Only the zero direction's output reaches the loss.
    backward(out, Tensor::from_values({1, 1, 0, 0}, {2, 2}, DType::Float64));
    for (double g : tex.grad().to_vector()) CHECK(g == 0);
    for (double g : dir.grad().to_vector()) CHECK(g == 0);
    if (mip) {
      for (double g : da.grad().to_vector()) CHECK(g == 0);
      for (double g : bias.grad().to_vector()) CHECK(g == 0);
    }
    for (Tensor* t : {&tex, &dir, &da, &bias}) t->zero_grad();
  }
}

TEST_CASE("cube_texture: an isotropic footprint and very short directions give finite gradients", "[ops][cube]") {
  Tensor tex = Tensor::uniform({6, 16, 16, 1}, 0, 1, 20, DType::Float64);
  // +Z centre, dX and dY of equal length along x and y: r = 0, where the
  // footprint's major axis is not differentiable (the 1/r terms are dropped).
  Tensor dir = Tensor::from_values({0.1, -0.05, 1}, {1, 3}, DType::Float64).set_requires_grad();
  Tensor da = Tensor::from_values({0.3, 0, 0, 0.3, 0, 0}, {1, 6}, DType::Float64).set_requires_grad();
  backward(sum(cube_texture(tex, dir, with(CubeFilter::Trilinear), da)));
  CHECK(gr::testing::all_finite(dir.grad()));
  CHECK(gr::testing::all_finite(da.grad()));
  double largest = 0;
  for (double g : da.grad().to_vector()) largest = std::max(largest, std::abs(g));
  CHECK(largest > 0);
  // Length 1e-200 and 1e-310 (subnormal): the same lookup as length 1; the
  // gradients stay finite (0 where 1/|ma|^3 overflows).
  const std::vector<double> unit = {0.3, -0.6, 0.8};
  const Tensor ref = cube_texture(tex, Tensor::from_values(unit, {1, 3}, DType::Float64), with(CubeFilter::Bilinear));
  for (double scale : {1e-200, 1e-310}) {
    INFO("scale " << scale);
    Tensor tiny = Tensor::from_values({unit[0] * scale, unit[1] * scale, unit[2] * scale}, {1, 3}, DType::Float64)
                      .set_requires_grad();
    Tensor tiny_da = Tensor::full({1, 6}, 0.01 * scale, DType::Float64).set_requires_grad();
    for (CubeFilter f : {CubeFilter::Bilinear, CubeFilter::Trilinear}) {
      Tensor out = cube_texture(tex, tiny, with(f), f == CubeFilter::Trilinear ? tiny_da : Tensor());
      if (f == CubeFilter::Bilinear) CHECK(out.at({0, 0}) == Approx(ref.at({0, 0})).epsilon(1e-12));
      backward(sum(out));
      CHECK(gr::testing::all_finite(tiny.grad()));
      tiny.zero_grad();
    }
    CHECK(gr::testing::all_finite(tiny_da.grad()));
  }
}

TEST_CASE("cube_texture: float32 agrees with float64", "[ops][cube]") {
  const int S = 8;
  Tensor tex64 = Tensor::uniform({6, S, S, 3}, -1, 1, 12, DType::Float64);
  Tensor dir64 = Tensor::uniform({500, 3}, -1, 1, 13, DType::Float64);
  Tensor da64 = Tensor::uniform({500, 6}, -0.2, 0.2, 14, DType::Float64);
  for (CubeFilter f : {CubeFilter::Nearest, CubeFilter::Bilinear, CubeFilter::LinearMipmapNearest, CubeFilter::Trilinear}) {
    const bool mip = raster::is_mipmapped(f);
    const std::vector<double> a = cube_texture(tex64, dir64, with(f), mip ? da64 : Tensor()).to_vector();
    const std::vector<double> b =
        cube_texture(cast(tex64, DType::Float32), cast(dir64, DType::Float32), with(f),
                     mip ? cast(da64, DType::Float32) : Tensor())
            .to_vector();
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
    // Nearest may pick another texel where float32 rounding moves s across a texel edge.
    if (f != CubeFilter::Nearest) CHECK(worst < 1e-5);
  }
}

TEST_CASE("cube_texture: outputs and gradients are bit-identical for 1, 2 and 8 threads", "[ops][cube]") {
  const std::int64_t n = 60000;
  Tensor tex0 = Tensor::uniform({6, 32, 32, 3}, 0, 1, 15);
  Tensor dir0 = Tensor::uniform({n, 3}, -1, 1, 16);
  Tensor da0 = Tensor::uniform({n, 6}, -0.1, 0.1, 17);
  Tensor bias0 = Tensor::uniform({n}, -0.5, 0.5, 18);
  Tensor g = Tensor::uniform({n, 3}, -1, 1, 19);
  for (CubeFilter f : {CubeFilter::Bilinear, CubeFilter::Trilinear}) {
    const bool mip = f == CubeFilter::Trilinear;
    std::vector<std::vector<double>> results[5];
    for (int threads : {1, 2, 8}) {
      set_num_threads(threads);
      Tensor tex = tex0.copy().set_requires_grad(), dir = dir0.copy().set_requires_grad();
      Tensor da = da0.copy().set_requires_grad(), bias = bias0.copy().set_requires_grad();
      Tensor out = cube_texture(tex, dir, with(f), mip ? da : Tensor(), mip ? bias : Tensor());
      backward(out, g);
      results[0].push_back(out.to_vector());
      results[1].push_back(tex.grad().to_vector());
      results[2].push_back(dir.grad().to_vector());
      if (mip) {
        results[3].push_back(da.grad().to_vector());
        results[4].push_back(bias.grad().to_vector());
      }
    }
    set_num_threads(0);
    for (const auto& r : results)
      for (std::size_t k = 1; k < r.size(); ++k) CHECK(r[k] == r[0]);
  }
}

TEST_CASE("cube_texture: bad arguments throw errors naming them", "[ops][cube][errors]") {
  Tensor tex = Tensor::ones({6, 4, 4, 3});
  Tensor dir = Tensor::full({2, 5, 3}, 0.5);
  CHECK(cube_texture(tex, dir).shape() == Shape{2, 5, 3});
  CHECK(cube_texture(Tensor::ones({6, 4, 4, 1}), Tensor::full({3}, 0.5)).shape() == Shape{1});
  for (const Shape& bad : {Shape{6, 4, 5, 3}, Shape{5, 4, 4, 3}, Shape{4, 4, 3}, Shape{6, 0, 0, 3}, Shape{6, 4, 4, 0}}) {
    INFO(bad.str());
    CHECK_THROWS_AS(cube_texture(Tensor::ones(bad), dir), ShapeError);
    CHECK_THROWS_WITH(cube_texture(Tensor::ones(bad), dir), Catch::Contains("'tex'") && Catch::Contains("[6, S, S, C]"));
  }
  CHECK_THROWS_WITH(cube_texture(tex, Tensor::ones({2, 2})), Catch::Contains("'dir'") && Catch::Contains("[..., 3]"));
  CHECK_THROWS_AS(cube_texture(tex, Tensor::ones({2, 3}, DType::Float64)), DTypeError);
  CHECK_THROWS_AS(cube_texture(Tensor::ones({6, 4, 4, 3}, DType::Int32), dir), DTypeError);
  Tensor nan_dir = Tensor::from_values({0.5, 0.1, 0.2, 0.3, std::numeric_limits<double>::quiet_NaN(), 1}, {2, 3});
  CHECK_THROWS_AS(cube_texture(tex, nan_dir), ValueError);
  CHECK_THROWS_WITH(cube_texture(tex, nan_dir), Catch::Contains("dir[4]") && Catch::Contains("NaN"));
  Tensor inf_dir = Tensor::from_values({std::numeric_limits<double>::infinity(), 0, 0}, {1, 3});
  CHECK_THROWS_WITH(cube_texture(tex, inf_dir), Catch::Contains("dir[0]"));
  Tensor tex_bad = tex.copy();
  tex_bad.data<float>()[50] = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH(cube_texture(tex_bad, dir), Catch::Contains("tex[50]"));
  // Mipmapped filters need dir_da or a bias, of the right shapes.
  const CubeTextureOptions tri = with(CubeFilter::Trilinear);
  CHECK_THROWS_WITH(cube_texture(tex, dir, tri), Catch::Contains("dir_da") && Catch::Contains("mip_level_bias"));
  CHECK_THROWS_WITH(cube_texture(tex, dir, tri, Tensor::ones({2, 5, 3})), Catch::Contains("'dir_da'"));
  CHECK_THROWS_AS(cube_texture(tex, dir, tri, Tensor::ones({2, 5, 6}, DType::Float64)), DTypeError);
  CHECK_THROWS_WITH(cube_texture(tex, dir, tri, {}, Tensor::ones({2, 4})), Catch::Contains("'mip_level_bias'"));
  Tensor nan_da = Tensor::full({2, 5, 6}, 0.1);
  nan_da.data<float>()[7] = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH(cube_texture(tex, dir, tri, nan_da), Catch::Contains("dir_da[7]"));
  Tensor inf_bias = Tensor::full({2, 5}, 0.1);
  inf_bias.data<float>()[3] = -std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH(cube_texture(tex, dir, tri, {}, inf_bias), Catch::Contains("mip_level_bias[3]"));
  CHECK_THROWS_WITH(cube_texture(tex, dir, with(CubeFilter::Bilinear), {}, Tensor::ones({2, 5})),
                    Catch::Contains("needs a mipmapped filter"));
  CHECK_THROWS_AS(cube_texture(tex, dir, with(CubeFilter::Trilinear, -2), Tensor::ones({2, 5, 6})), ValueError);
  // Bilinear ignores dir_da, whatever it holds.
  CHECK_NOTHROW(cube_texture(tex, dir, with(CubeFilter::Bilinear), nan_da));
}
