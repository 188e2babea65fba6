// Tests of the texture op and of interpolate's screen-space derivatives:
// gradchecks of bilinear and trilinear lookups w.r.t. texels and uv for every
// addressing mode (with samples across repeat seams and beyond clamp borders),
// nearest values and gradients, mip/bilinear consistency, constant textures,
// gradient mass through the pyramid, determinism, derivatives against exact
// values and finite differences across pixels, and bad arguments.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/render/interpolate.h"
#include "ops/render/rasterize.h"
#include "ops/render/resample.h"
#include "ops/tensor/reduce.h"
#include "ops/render/texture.h"
#include "ops/tensor/elementwise.h"
#include "raster/mipmap.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

const char* wrap_name(Wrap w) {
  return w == Wrap::Repeat ? "repeat" : w == Wrap::Clamp ? "clamp" : w == Wrap::Mirror ? "mirror" : "zero";
}

// Distance of t to the nearest integer.
double to_integer(double t) { return std::abs(t - std::round(t)); }

// True if (u, v) is at least `margin` texels away from every cell boundary of
// the levels in [first, last] of `layout`, so gradcheck's +-2 eps steps stay on
// one smooth piece of the bilinear lookups.
bool away_from_cells(const raster::MipLayout& layout, int first, int last, double u, double v, double margin) {
  for (int l = first; l <= last && l < layout.count(); ++l) {
    const raster::MipLevel& lv = layout.levels[l];
    if (to_integer(u * lv.width - 0.5) < margin || to_integer((1 - v) * lv.height - 0.5) < margin) return false;
  }
  return true;
}

// n uv samples in [lo, hi)^2, each away from the cell boundaries of levels
// [first, last]; the first ones are forced near the repeat seam (u ~ 0 and 1)
// and beyond the clamp borders (u, v outside [0, 1]).
Tensor sample_uv(std::int64_t n, const raster::MipLayout& layout, int first, int last, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-0.35, 1.35);
  const double forced[][2] = {{0.01, 0.5}, {0.995, 0.3}, {-0.02, 0.97}, {1.01, 0.02}, {-0.3, 0.4}, {0.6, 1.3}, {1.2, -0.25}};
  std::vector<double> uv;
  for (std::int64_t i = 0; i < n; ++i) {
    double u = 0, v = 0;
    for (int attempt = 0;; ++attempt) {
      if (i < 7 && attempt < 50) {
        // Jitter the forced point until it is clear of the cells.
        u = forced[i][0] + 0.002 * attempt * ((attempt & 1) ? 1 : -1);
        v = forced[i][1] + 0.0013 * attempt;
      } else {
        u = d(rng);
        v = d(rng);
      }
      if (away_from_cells(layout, first, last, u, v, 0.05)) break;
    }
    uv.push_back(u);
    uv.push_back(v);
  }
  Tensor t = Tensor::from_values(uv, {n, 2}, DType::Float64);
  return t;
}

// Derivatives giving LOD `lod` for a base texture of width w (footprint along x).
void lod_derivatives(const std::vector<double>& lods, int w, Tensor* dx, Tensor* dy) {
  std::vector<double> a, b;
  for (double lod : lods) {
    a.push_back(std::pow(2.0, lod) / w);
    a.push_back(0.0);
    b.push_back(0.0);
    b.push_back(1e-4);
  }
  const std::int64_t n = static_cast<std::int64_t>(lods.size());
  *dx = Tensor::from_values(a, {n, 2}, DType::Float64);
  *dy = Tensor::from_values(b, {n, 2}, DType::Float64);
}

}  // namespace

TEST_CASE("texture: bilinear gradients w.r.t. texels and uv match finite differences across seams and borders", "[ops][texture][gradcheck]") {
  const int th = 5, tw = 6;
  const raster::MipLayout layout = raster::mip_layout(th, tw, 0);
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Zero}) {
    INFO(wrap_name(wrap));
    Tensor tex = random_input({th, tw, 3}, -1, 1, 11);
    Tensor uv = sample_uv(24, layout, 0, 0, 5).set_requires_grad();
    TextureOptions opt;
    opt.wrap = wrap;
    require_gradcheck(std::string("texture bilinear ") + wrap_name(wrap),
                      [&](const Inputs& in) { return texture(in[0], in[1], opt); }, {tex, uv});
  }
}

TEST_CASE("texture: trilinear gradients w.r.t. texels of every level and uv match finite differences", "[ops][texture][gradcheck]") {
  // 16 x 12 -> 8 x 6 -> 4 x 3 -> 2 x 1 -> 1 x 1; LODs inside levels (0.4, 1.3,
  // 2.6, 3.5) and beyond the last one. The LOD is a stop-gradient, so only uv
  // and the texels are differentiated; uv avoids cell boundaries on all levels.
  const int th = 12, tw = 16;
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  REQUIRE(layout.count() == 5);
  const std::vector<double> lods = {0.4, 1.3, 2.6, 3.5, 7.0};
  std::vector<double> per_sample;
  for (int i = 0; i < 20; ++i) per_sample.push_back(lods[i % lods.size()]);
  Tensor dx, dy;
  lod_derivatives(per_sample, tw, &dx, &dy);
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Zero}) {
    INFO(wrap_name(wrap));
    Tensor tex = random_input({th, tw, 2}, -1, 1, 21);
    Tensor uv = sample_uv(20, layout, 0, 4, 8).set_requires_grad();
    TextureOptions opt;
    opt.filter = Filter::Trilinear;
    opt.wrap = wrap;
    require_gradcheck(std::string("texture trilinear ") + wrap_name(wrap),
                      [&](const Inputs& in) { return texture(in[0], in[1], opt, dx, dy); }, {tex, uv});
  }
  SECTION("with max_mip_level limiting the chain") {
    Tensor tex = random_input({th, tw, 2}, -1, 1, 22);
    Tensor uv = sample_uv(20, layout, 0, 2, 9).set_requires_grad();
    TextureOptions opt;
    opt.filter = Filter::Trilinear;
    opt.max_mip_level = 2;
    require_gradcheck("texture trilinear max level 2",
                      [&](const Inputs& in) { return texture(in[0], in[1], opt, dx, dy); }, {tex, uv});
  }
}

TEST_CASE("texture: max_mip_level stops a far-away footprint at that level instead of the 1 x 1 mean", "[ops][texture]") {
  // 8 x 8 -> 4 x 4 -> 2 x 2 -> 1 x 1. du/dx = 4 is a footprint of 32 texels
  // (LOD 5, beyond the chain): the lookup must read level max_mip_level alone,
  // i.e. a bilinear lookup of the base texture box-filtered to that level.
  Tensor tex = random_input({8, 8, 2}, -1, 1, 31);
  Tensor uv = random_input({10, 2}, 0.05, 0.95, 32);
  Tensor dx = Tensor::full(uv.shape(), 4.0, DType::Float64), dy = Tensor::zeros(uv.shape(), DType::Float64);
  for (int max_level : {0, 1, 2}) {
    INFO("max_mip_level " << max_level);
    TextureOptions opt;
    opt.filter = Filter::Trilinear;
    opt.max_mip_level = max_level;
    Tensor limited = texture(tex, uv, opt, dx, dy);
    Tensor expected = texture(max_level == 0 ? tex : downsample_box(tex, 1 << max_level), uv);
    for (std::int64_t i = 0; i < limited.numel(); ++i)
      CHECK(limited.data<double>()[i] == Approx(expected.data<double>()[i]).margin(1e-12));
  }
}

TEST_CASE("texture: nearest returns the picked texel and sends its gradient only there", "[ops][texture]") {
  Tensor tex = Tensor::from_values({10, 20, 30, 40, 50, 60}, {2, 3, 1}, DType::Float64).set_requires_grad();
  // Bottom-right texel (row 1, column 2) and, through repeat, top-left.
  Tensor uv = Tensor::from_values({0.9, 0.2, 1.1, 0.9}, {2, 2}, DType::Float64).set_requires_grad();
  TextureOptions opt;
  opt.filter = Filter::Nearest;
  Tensor out = texture(tex, uv, opt);
  REQUIRE(out.shape() == Shape{2, 1});
  CHECK(out.at({0, 0}) == 60);
  CHECK(out.at({1, 0}) == 10);
  backward(out, Tensor::from_values({2, 3}, {2, 1}, DType::Float64));
  CHECK(tex.grad().to_vector() == std::vector<double>{3, 0, 0, 0, 0, 2});
  CHECK(uv.grad().to_vector() == std::vector<double>(4, 0.0));  // piecewise constant: zero gradient to uv
}

TEST_CASE("texture: trilinear at level 0 equals bilinear when the derivatives are tiny", "[ops][texture]") {
  Tensor tex = Tensor::uniform({9, 14, 3}, 0, 1, 3, DType::Float64);
  Tensor uv = Tensor::uniform({6, 7, 2}, -0.5, 1.5, 4, DType::Float64);
  Tensor tiny = Tensor::full({6, 7, 2}, 1e-6, DType::Float64);
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Zero}) {
    TextureOptions bil, tri;
    bil.wrap = tri.wrap = wrap;
    tri.filter = Filter::Trilinear;
    const std::vector<double> a = texture(tex, uv, bil).to_vector(), b = texture(tex, uv, tri, tiny, tiny).to_vector();
    REQUIRE(a.size() == b.size());
    for (std::size_t i = 0; i < a.size(); ++i) CHECK(a[i] == b[i]);
  }
}

TEST_CASE("texture: a constant texture stays constant at every level of detail", "[ops][texture]") {
  Tensor tex = Tensor::full({13, 7, 2}, 0.625, DType::Float32);  // odd sides
  const int levels = raster::mip_layout(13, 7).count();
  std::vector<double> lods;
  for (double lod = 0; lod <= levels + 1; lod += 0.25) lods.push_back(lod);
  const std::int64_t n = static_cast<std::int64_t>(lods.size());
  Tensor dx64, dy64;
  lod_derivatives(lods, 7, &dx64, &dy64);
  Tensor dx = Tensor::from_values(dx64.to_vector(), {n, 2}), dy = Tensor::from_values(dy64.to_vector(), {n, 2});
  Tensor uv = Tensor::uniform({n, 2}, -2, 3, 6);
  // (Not Wrap::Zero: outside [0, 1] it reads zeros by design.)
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror}) {
    TextureOptions opt;
    opt.filter = Filter::Trilinear;
    opt.wrap = wrap;
    for (double x : texture(tex, uv, opt, dx, dy).to_vector()) CHECK(x == Approx(0.625).epsilon(1e-6));
  }
}

TEST_CASE("texture: trilinear texel gradients sum to the incoming gradient through the pyramid", "[ops][texture]") {
  // Tap weights sum to one on each level and the box adjoint preserves sums.
  Tensor tex = Tensor::uniform({11, 10, 2}, 0, 1, 7, DType::Float64).set_requires_grad();
  Tensor uv = Tensor::uniform({50, 2}, -1, 2, 8, DType::Float64);
  Tensor dx = Tensor::uniform({50, 2}, -0.5, 0.5, 9, DType::Float64);
  Tensor dy = Tensor::uniform({50, 2}, -0.01, 0.01, 10, DType::Float64);
  Tensor g = Tensor::uniform({50, 2}, -1, 1, 11, DType::Float64);
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  backward(texture(tex, uv, opt, dx, dy), g);
  const std::vector<double> gt = tex.grad().to_vector(), gg = g.to_vector();
  double st[2] = {0, 0}, sg[2] = {0, 0};
  for (std::size_t i = 0; i < gt.size(); ++i) st[i % 2] += gt[i];
  for (std::size_t i = 0; i < gg.size(); ++i) sg[i % 2] += gg[i];
  CHECK(st[0] == Approx(sg[0]).epsilon(1e-12));
  CHECK(st[1] == Approx(sg[1]).epsilon(1e-12));
}

TEST_CASE("texture: gradients are bit-identical for 1, 2 and 8 threads", "[ops][texture]") {
  Tensor tex0 = Tensor::uniform({64, 48, 3}, 0, 1, 12);
  Tensor uv0 = Tensor::uniform({200, 150, 2}, -0.2, 1.2, 13);
  Tensor dx = Tensor::uniform({200, 150, 2}, -0.05, 0.05, 14);
  Tensor dy = Tensor::uniform({200, 150, 2}, -0.05, 0.05, 15);
  Tensor g = Tensor::uniform({200, 150, 3}, -1, 1, 16);
  for (Filter f : {Filter::Bilinear, Filter::Trilinear}) {
    std::vector<std::vector<double>> tex_grads, uv_grads, outs;
    for (int threads : {1, 2, 8}) {
      set_num_threads(threads);
      Tensor tex = tex0.copy().set_requires_grad();
      Tensor uv = uv0.copy().set_requires_grad();
      TextureOptions opt;
      opt.filter = f;
      Tensor out = texture(tex, uv, opt, dx, dy);
      backward(out, g);
      outs.push_back(out.to_vector());
      tex_grads.push_back(tex.grad().to_vector());
      uv_grads.push_back(uv.grad().to_vector());
    }
    set_num_threads(0);
    for (int k : {1, 2}) {
      CHECK(outs[0] == outs[k]);
      CHECK(tex_grads[0] == tex_grads[k]);
      CHECK(uv_grads[0] == uv_grads[k]);
    }
  }
}

TEST_CASE("texture: the level of detail is differentiable: uv_dx uv_dy and mip_level_bias match finite differences",
          "[ops][texture][gradcheck]") {
  // 16 x 12 -> 5 levels. LODs strictly inside levels (not at integers, where
  // the LOD's derivative jumps), the footprint along x in some samples and
  // along y in others, random directions; the bias moves some across a level.
  const int th = 12, tw = 16;
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  const std::int64_t n = 16;
  std::vector<double> dxv, dyv, biasv;
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> angle(0, 6.283), frac(0.15, 0.85), small(0.1, 0.6);
  for (std::int64_t i = 0; i < n; ++i) {
    const double lod = (i % 3) + frac(rng), a = angle(rng), major = std::pow(2.0, lod) / tw;
    const double minor = major * small(rng);
    const bool along_x = i % 2 == 0;
    const double big[2] = {major * std::cos(a), major * std::sin(a) * tw / th};
    const double little[2] = {-minor * std::sin(a), minor * std::cos(a) * tw / th};
    for (int k = 0; k < 2; ++k) dxv.push_back(along_x ? big[k] : little[k]);
    for (int k = 0; k < 2; ++k) dyv.push_back(along_x ? little[k] : big[k]);
    biasv.push_back(i % 4 == 1 ? 0.37 : i % 4 == 3 ? -0.21 : 0.0);
  }
  Tensor dx = Tensor::from_values(dxv, {n, 2}, DType::Float64).set_requires_grad();
  Tensor dy = Tensor::from_values(dyv, {n, 2}, DType::Float64).set_requires_grad();
  Tensor bias = Tensor::from_values(biasv, {n}, DType::Float64).set_requires_grad();
  Tensor tex = random_input({th, tw, 2}, -1, 1, 23);
  Tensor uv = sample_uv(n, layout, 0, 4, 10).set_requires_grad();
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  require_gradcheck("texture lod: tex, uv, uv_dx, uv_dy, bias",
                    [&](const Inputs& in) { return texture(in[0], in[1], opt, in[2], in[3], in[4]); },
                    {tex, uv, dx, dy, bias});
  // The LOD's gradient is not zero (a constant texture would make it so).
  backward(sum(texture(tex, uv, opt, dx, dy, bias)));
  double largest = 0;
  for (double g : bias.grad().to_vector()) largest = std::max(largest, std::abs(g));
  CHECK(largest > 1e-3);
}

TEST_CASE("texture: a clamped level of detail passes no gradient to the derivatives or the bias", "[ops][texture]") {
  Tensor tex = Tensor::uniform({8, 8, 1}, 0, 1, 17, DType::Float64).set_requires_grad();
  Tensor uv = Tensor::uniform({5, 2}, 0, 1, 18, DType::Float64);
  // Magnified (LOD < 0) and beyond the last level (LOD > 3): both clamped.
  Tensor dx = Tensor::from_values({1e-3, 0, 1e-3, 0, 1e-3, 0, 40, 0, 40, 0}, {5, 2}, DType::Float64).set_requires_grad();
  Tensor dy = Tensor::full({5, 2}, 1e-4, DType::Float64).set_requires_grad();
  Tensor bias = Tensor::zeros({5}, DType::Float64).set_requires_grad();
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  backward(sum(texture(tex, uv, opt, dx, dy, bias)));
  CHECK(dx.grad().to_vector() == std::vector<double>(10, 0.0));
  CHECK(dy.grad().to_vector() == std::vector<double>(10, 0.0));
  CHECK(bias.grad().to_vector() == std::vector<double>(5, 0.0));
  // A bias of +1 at LOD 0.25 reads what LOD 1.25 reads.
  Tensor lod_quarter = Tensor::full({5, 2}, std::pow(2.0, 0.25) / 8 / std::sqrt(2.0), DType::Float64);
  Tensor lod_five_quarters = Tensor::full({5, 2}, std::pow(2.0, 1.25) / 8 / std::sqrt(2.0), DType::Float64);
  const std::vector<double> biased =
      texture(tex.detach(), uv, opt, lod_quarter, lod_quarter, Tensor::full({5}, 1.0, DType::Float64)).to_vector();
  const std::vector<double> direct = texture(tex.detach(), uv, opt, lod_five_quarters, lod_five_quarters).to_vector();
  for (std::size_t i = 0; i < biased.size(); ++i) CHECK(biased[i] == Approx(direct[i]).epsilon(1e-12));
  CHECK_THROWS_WITH(texture(tex, uv, TextureOptions{}, {}, {}, bias), Catch::Contains("needs a mipmapped filter"));
  CHECK_THROWS_WITH(texture(tex, uv, opt, dx, dy, Tensor::zeros({4}, DType::Float64)), Catch::Contains("mip_level_bias"));
  CHECK_THROWS_WITH(texture(tex, uv, opt, dx, dy, Tensor::full({5}, std::nan(""), DType::Float64)),
                    Catch::Contains("mip_level_bias"));
}

TEST_CASE("texture: bad arguments throw errors naming them", "[ops][texture][errors]") {
  Tensor tex = Tensor::ones({4, 4, 3});
  Tensor uv = Tensor::full({2, 3, 2}, 0.5);
  CHECK_THROWS_WITH(texture(Tensor::ones({0, 4, 3}), uv), Catch::Contains("'tex'"));
  CHECK_THROWS_AS(texture(Tensor::ones({0, 4, 3}), uv), ShapeError);
  CHECK_THROWS_AS(texture(Tensor::ones({4, 4, 0}), uv), ShapeError);
  CHECK_THROWS_WITH(texture(Tensor::ones({4, 4}), uv), Catch::Contains("'tex'") && Catch::Contains("[Ht, Wt, C]"));
  CHECK_THROWS_WITH(texture(tex, Tensor::ones({2, 3, 3})), Catch::Contains("'uv'") && Catch::Contains("[..., 2]"));
  CHECK_THROWS_AS(texture(tex, Tensor::ones({2, 3, 2}, DType::Float64)), DTypeError);
  CHECK_THROWS_AS(texture(Tensor::ones({4, 4, 3}, DType::Int32), uv), DTypeError);
  CHECK_THROWS_AS(texture(tex, Tensor()), ValueError);
  TextureOptions tri;
  tri.filter = Filter::Trilinear;
  CHECK_THROWS_WITH(texture(tex, uv, tri), Catch::Contains("uv_dx"));
  CHECK_THROWS_WITH(texture(tex, uv, tri, uv), Catch::Contains("uv_dy"));
  CHECK_THROWS_WITH(texture(tex, uv, tri, uv, Tensor::ones({2, 2, 2})), Catch::Contains("uv_dy") && Catch::Contains("shape"));
  CHECK_THROWS_AS(texture(tex, uv, tri, uv, Tensor::ones({2, 3, 2}, DType::Float64)), DTypeError);
  TextureOptions bad_level;
  bad_level.max_mip_level = -2;
  CHECK_THROWS_AS(texture(tex, uv, bad_level), ValueError);
  Tensor nan_uv = Tensor::from_values({0.5, std::numeric_limits<double>::quiet_NaN()}, {1, 2});
  CHECK_THROWS_WITH(texture(tex, nan_uv), Catch::Contains("uv[1]") && Catch::Contains("NaN"));
  Tensor inf_dx = Tensor::from_values({0.5, std::numeric_limits<double>::infinity()}, {1, 2});
  CHECK_THROWS_WITH(texture(tex, Tensor::full({1, 2}, 0.5), tri, inf_dx, inf_dx), Catch::Contains("uv_dx[1]"));
  // Output shape follows uv's leading axes.
  CHECK(texture(tex, Tensor::full({2}, 0.5)).shape() == Shape{3});
  CHECK(texture(tex, Tensor::full({2, 1, 3, 2}, 0.5)).shape() == Shape{2, 1, 3, 3});
}

// ---- screen-space derivatives from interpolate ----

namespace {

// A floor quad from z = +2 (behind the camera: crosses the near plane) to
// z = -14, plus a tilted triangle in front of it, through a GL perspective.
struct Scene {
  Tensor world, clip, tris;
  Scene() {
    const std::vector<double> p = {-3, -1, 2, 3, -1, 2, 3, -1, -14, -3, -1, -14,  //
                                   -1.2, -0.8, -4, 1.0, -0.6, -5.5, 0.1, 0.9, -4.5};
    world = Tensor::from_values(p, {7, 3}, DType::Float64);
    const double n = 0.1, f = 50, fy = 1 / std::tan(0.5), aspect = 1.25;
    std::vector<double> c;
    for (int i = 0; i < 7; ++i) {
      const double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
      c.insert(c.end(), {fy / aspect * x, fy * y, (f + n) / (n - f) * z + 2 * f * n / (n - f), -z});
    }
    clip = Tensor::from_values(c, {7, 4}, DType::Float64);
    tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 0, 2, 3, 4, 5, 6}, {3, 3});
  }
};

}  // namespace

TEST_CASE("interpolate with derivatives: screen positions on a triangle of constant w have unit derivatives",
          "[ops][interpolate][texture]") {
  Scene s;
  const int W = 40, H = 32;
  // The unclipped triangle divided by w: its barycentrics are affine in screen space.
  std::vector<double> ndc, screen;
  for (int i = 4; i < 7; ++i) {
    const double w = s.clip.at({i, 3});
    for (int c = 0; c < 3; ++c) ndc.push_back(s.clip.at({i, c}) / w);
    ndc.push_back(1.0);
    screen.push_back(0.5 * W * (1 + s.clip.at({i, 0}) / w));
    screen.push_back(0.5 * H * (1 - s.clip.at({i, 1}) / w));
  }
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  RasterizeOptions o{W, H};
  o.derivatives = true;
  GBuffer gb = rasterize(Tensor::from_values(ndc, {3, 4}, DType::Float64), tris, o);
  auto r = interpolate_with_derivatives(Tensor::from_values(screen, {3, 2}, DType::Float64), gb, tris);
  int covered = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      if (gb.tri_id.at({j, i}) == 0) {
        CHECK(r.d_dx.at({j, i, 0}) == 0);
        continue;
      }
      ++covered;
      CHECK(r.values.at({j, i, 0}) == Approx(i + 0.5).epsilon(1e-12));
      CHECK(r.values.at({j, i, 1}) == Approx(j + 0.5).epsilon(1e-12));
      CHECK(r.d_dx.at({j, i, 0}) == Approx(1).epsilon(1e-12));
      CHECK(r.d_dx.at({j, i, 1}) == Approx(0).margin(1e-12));
      CHECK(r.d_dy.at({j, i, 0}) == Approx(0).margin(1e-12));
      CHECK(r.d_dy.at({j, i, 1}) == Approx(1).epsilon(1e-12));
    }
  CHECK(covered > 20);
}

TEST_CASE("interpolate with derivatives: perspective clip position gives d(ndc)/d(screen) exactly, clipped triangles too", "[ops][interpolate][texture]") {
  Scene s;
  const int W = 40, H = 32;
  RasterizeOptions o{W, H};
  o.derivatives = true;
  GBuffer gb = rasterize(s.clip, s.tris, o);
  REQUIRE(gb.stats.clipped_near == 2);
  // Perspective interpolation of the clip position is the surface point's clip
  // position, so d(x/w)/dx = 2/W and d(y/w)/dy = -2/H (y down).
  auto r = interpolate_with_derivatives(s.clip, gb, s.tris);
  int covered = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      if (gb.tri_id.at({j, i}) == 0) continue;
      ++covered;
      const double x = r.values.at({j, i, 0}), y = r.values.at({j, i, 1}), w = r.values.at({j, i, 3});
      const double ndx = (r.d_dx.at({j, i, 0}) * w - x * r.d_dx.at({j, i, 3})) / (w * w);
      const double ndy = (r.d_dy.at({j, i, 1}) * w - y * r.d_dy.at({j, i, 3})) / (w * w);
      const double cross_x = (r.d_dy.at({j, i, 0}) * w - x * r.d_dy.at({j, i, 3})) / (w * w);
      CHECK(ndx == Approx(2.0 / W).epsilon(1e-9));
      CHECK(ndy == Approx(-2.0 / H).epsilon(1e-9));
      CHECK(cross_x == Approx(0).margin(1e-10));
    }
  CHECK(covered > 400);
}

TEST_CASE("interpolate with derivatives: derivatives match finite differences across neighbouring pixels", "[ops][interpolate][texture]") {
  Scene s;
  // A fine image: the curvature near the horizon spans many pixels, so the
  // fourth-order differences' truncation error stays well below 1e-4.
  const int W = 288, H = 240;
  RasterizeOptions o{W, H};
  o.derivatives = true;
  GBuffer gb = rasterize(s.clip, s.tris, o);
  // Texture coordinates of the floor and the wall, smooth per triangle.
  std::vector<double> a;
  for (int i = 0; i < 7; ++i) {
    a.push_back(s.world.at({i, 0}) / 6 + 0.5);
    a.push_back(-s.world.at({i, 2}) / 8 + 0.3 * s.world.at({i, 1}));
  }
  Tensor attr = Tensor::from_values(a, {7, 2}, DType::Float64);
  {
    auto r = interpolate_with_derivatives(attr, gb, s.tris);
    const std::vector<double> values = r.values.to_vector(), dx = r.d_dx.to_vector(), dy = r.d_dy.to_vector();
    CHECK(values == interpolate(attr, gb, s.tris).to_vector());
    auto id = [&](int j, int i) { return gb.tri_id.at({j, i}); };
    auto val = [&](int j, int i, int c) { return values[(j * W + i) * 2 + c]; };
    double worst = 0;
    int checked = 0;
    for (int j = 2; j < H - 2; ++j)
      for (int i = 2; i < W - 2; ++i) {
        const auto t = id(j, i);
        if (t == 0) continue;
        bool same = true;
        for (int k = -2; k <= 2; ++k) same = same && id(j, i + k) == t && id(j + k, i) == t;
        if (!same) continue;
        ++checked;
        for (int c = 0; c < 2; ++c) {
          // Fourth-order central differences with a one-pixel step.
          const double fx = (8 * (val(j, i + 1, c) - val(j, i - 1, c)) - (val(j, i + 2, c) - val(j, i - 2, c))) / 12;
          const double fy = (8 * (val(j + 1, i, c) - val(j - 1, i, c)) - (val(j + 2, i, c) - val(j - 2, i, c))) / 12;
          const double ax = dx[(j * W + i) * 2 + c], ay = dy[(j * W + i) * 2 + c];
          worst = std::max(worst, std::abs(fx - ax) / std::max(std::abs(ax), 1e-3));
          worst = std::max(worst, std::abs(fy - ay) / std::max(std::abs(ay), 1e-3));
        }
      }
    INFO("worst relative error " << worst << " over " << checked << " pixels");
    CHECK(checked > 10000);
    CHECK(worst < 2e-4);
  }
}

TEST_CASE("texture: a rendered floor samples coarser levels farther away and passes gradients to the texture", "[ops][texture][gradcheck]") {
  Scene s;
  const int W = 24, H = 20;
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 0, 2, 3}, {2, 3});
  RasterizeOptions o{W, H};
  o.derivatives = true;
  GBuffer gb = rasterize(s.clip, tris, o);
  std::vector<double> a;
  for (int i = 0; i < 7; ++i) {
    a.push_back(s.world.at({i, 0}) / 6 + 0.5);
    a.push_back(-s.world.at({i, 2}) / 4);
  }
  auto r = interpolate_with_derivatives(Tensor::from_values(a, {7, 2}, DType::Float64), gb, tris);
  // Footprint (texels per pixel for a 16 x 16 texture) grows towards the horizon.
  auto footprint = [&](int j) {
    const int i = W / 2;
    return std::hypot(r.d_dy.at({j, i, 0}) * 16, r.d_dy.at({j, i, 1}) * 16);
  };
  int row_far = -1, row_near = -1;
  for (int j = 0; j < H; ++j)
    if (gb.tri_id.at({j, W / 2}) != 0) {
      if (row_far < 0) row_far = j;
      row_near = j;
    }
  REQUIRE(row_far >= 0);
  REQUIRE(row_near > row_far + 2);
  CHECK(footprint(row_far) > 2 * footprint(row_near));
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  Tensor tex = random_input({16, 16, 1}, 0, 1, 30);
  GradcheckOptions go;
  go.eps = 1e-3;  // linear in the texels
  require_gradcheck("texture trilinear rendered floor",
                    [&](const Inputs& in) { return texture(in[0], r.values, opt, r.d_dx, r.d_dy); }, {tex}, go);
}

TEST_CASE("texture: NaN or Inf texels are refused with the texel named", "[ops][texture][errors]") {
  TextureOptions tri;
  tri.filter = Filter::Trilinear;
  for (double bad : {std::nan(""), std::numeric_limits<double>::infinity()})
    for (DType dtype : {DType::Float32, DType::Float64}) {
      Tensor tex = Tensor::ones({4, 4, 3}, dtype);
      Tensor uv_d = Tensor::full({2, 3, 2}, 0.5, dtype);
      Tensor zero_d = Tensor::zeros({2, 3, 2}, dtype);
      Tensor tex_bad = tex.copy();
      if (dtype == DType::Float32)
        tex_bad.data<float>()[29] = float(bad);
      else
        tex_bad.data<double>()[29] = bad;
      CHECK_THROWS_AS(texture(tex_bad, uv_d), ValueError);
      CHECK_THROWS_WITH(texture(tex_bad, uv_d), Catch::Contains("texture") && Catch::Contains("tex[29]"));
      CHECK_THROWS_AS(texture(tex_bad, uv_d, tri, zero_d, zero_d), ValueError);
      CHECK_NOTHROW(texture(tex, uv_d));
    }
}

namespace {

// The box-filtered levels 1.. of tex, as separate tensors (what a user might pass).
std::vector<Tensor> box_levels(const Tensor& tex) {
  const raster::MipLayout layout = raster::mip_layout(static_cast<int>(tex.size(0)), static_cast<int>(tex.size(1)));
  const std::int64_t C = tex.size(2), base = tex.size(0) * tex.size(1);
  std::vector<double> pyramid(static_cast<std::size_t>((layout.total_texels - base) * C));
  raster::mip_build(tex.to_vector().data(), C, layout, pyramid.data());
  std::vector<Tensor> levels;
  std::int64_t at = 0;
  for (int l = 1; l < layout.count(); ++l) {
    const raster::MipLevel& lv = layout.levels[l];
    const std::int64_t n = std::int64_t(lv.height) * lv.width * C;
    levels.push_back(Tensor::from_values(std::vector<double>(pyramid.begin() + at, pyramid.begin() + at + n),
                                         {lv.height, lv.width, C}, DType::Float64));
    at += n;
  }
  return levels;
}

}  // namespace

TEST_CASE("texture: a user mip stack equal to the box pyramid gives the same image, bit for bit", "[ops][texture]") {
  const Tensor tex = Tensor::uniform({12, 16, 3}, 0, 1, 41, DType::Float64);
  const raster::MipLayout layout = raster::mip_layout(12, 16);
  const std::vector<double> lods = {0.3, 1.6, 2.2, 3.7, 4.0, 6.5};
  Tensor dx, dy;
  lod_derivatives(lods, 16, &dx, &dy);
  const Tensor uv = sample_uv(6, layout, 0, 4, 12);
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  CHECK(texture(tex, uv, opt, dx, dy, {}, box_levels(tex)).to_vector() == texture(tex, uv, opt, dx, dy).to_vector());
}

TEST_CASE("texture: every level of a user mip stack gets its own gradient, matching finite differences",
          "[ops][texture][gradcheck]") {
  const int th = 12, tw = 16;
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  std::vector<Tensor> inputs{random_input({th, tw, 2}, -1, 1, 42)};
  std::uint64_t seed = 43;
  for (const Tensor& level : box_levels(inputs[0])) inputs.push_back(random_input(level.shape(), -1, 1, seed++));
  const std::vector<double> lods = {0.4, 1.3, 2.6, 3.5, 1.7, 0.8};
  Tensor dx, dy;
  lod_derivatives(lods, tw, &dx, &dy);
  Tensor uv = sample_uv(6, layout, 0, 4, 13).set_requires_grad();
  inputs.push_back(uv);
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  auto f = [&](const Inputs& in) {
    const std::vector<Tensor> mip(in.begin() + 1, in.end() - 1);
    return texture(in[0], in.back(), opt, dx, dy, {}, mip);
  };
  require_gradcheck("texture user mip stack", f, inputs);

  SECTION("with every footprint on levels 1 and 2, nothing reaches the base texture or level 3") {
    Tensor tex = random_input({th, tw, 1}, -1, 1, 50);
    std::vector<Tensor> mip;
    for (const Tensor& level : box_levels(tex)) mip.push_back(Tensor::zeros(level.shape(), DType::Float64).set_requires_grad());
    Tensor dx1, dy1;
    lod_derivatives({1.25, 1.5, 1.75}, tw, &dx1, &dy1);
    backward(sum(texture(tex, sample_uv(3, layout, 1, 2, 14), opt, dx1, dy1, {}, mip)));
    auto total = [](const Tensor& g) {
      double s = 0;
      for (double x : g.to_vector()) s += std::abs(x);
      return s;
    };
    CHECK(total(tex.grad()) == 0);
    CHECK(total(mip[0].grad()) > 0);
    CHECK(total(mip[1].grad()) > 0);
    CHECK(total(mip[2].grad()) == 0);
  }
}

TEST_CASE("texture: a mip stack of the wrong sizes or count is refused by name", "[ops][texture][errors]") {
  const Tensor tex = Tensor::uniform({12, 16, 2}, 0, 1, 44, DType::Float64);
  const Tensor uv = Tensor::uniform({3, 2}, 0, 1, 45, DType::Float64);
  const Tensor d = Tensor::full({3, 2}, 0.1, DType::Float64);
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  std::vector<Tensor> mip = box_levels(tex);  // 6x8, 3x4, 1x2, 1x1
  std::vector<Tensor> wrong = mip;
  wrong[1] = Tensor::zeros({4, 4, 2}, DType::Float64);
  CHECK_THROWS_WITH(texture(tex, uv, opt, d, d, {}, wrong), Catch::Contains("mip[1]"));
  std::vector<Tensor> too_many = mip;
  too_many.push_back(Tensor::zeros({1, 1, 2}, DType::Float64));
  CHECK_THROWS_WITH(texture(tex, uv, opt, d, d, {}, too_many), Catch::Contains("halves to 1 x 1 in 4"));
  CHECK_THROWS_WITH(texture(tex, uv, TextureOptions{}, {}, {}, {}, mip), Catch::Contains("needs a mipmapped filter"));
  std::vector<Tensor> two(mip.begin(), mip.begin() + 2);
  CHECK(texture(tex, uv, opt, d, d, {}, two).shape() == Shape({3, 2}));  // a shorter chain: max_mip_level 2
  opt.max_mip_level = 3;
  CHECK_THROWS_WITH(texture(tex, uv, opt, d, d, {}, two), Catch::Contains("max_mip_level"));
}

TEST_CASE("texture: the major-axis LOD rule's gradients to uv_dx, uv_dy and the bias match finite differences",
          "[ops][texture][gradcheck]") {
  const int th = 16, tw = 16;
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  // Sheared footprints of 1.5..6 texels (LODs inside levels 0..2, away from integers and from a = b).
  Tensor dx = Tensor::from_values({2.1 / tw, 0.7 / th, 3.3 / tw, -1.2 / th, 0.4 / tw, 2.6 / th}, {3, 2}, DType::Float64);
  Tensor dy = Tensor::from_values({0.9 / tw, 1.9 / th, -1.1 / tw, 2.2 / th, 3.0 / tw, 0.8 / th}, {3, 2}, DType::Float64);
  dx.set_requires_grad();
  dy.set_requires_grad();
  Tensor bias = random_input({3}, -0.2, 0.2, 61);
  Tensor tex = random_input({th, tw, 2}, -1, 1, 62);
  Tensor uv = sample_uv(3, layout, 0, 2, 63).set_requires_grad();
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  opt.lod_rule = LodRule::MajorAxis;
  require_gradcheck("texture major-axis LOD",
                    [&](const Inputs& in) { return texture(in[0], in[1], opt, in[2], in[3], in[4]); },
                    {tex, uv, dx, dy, bias});
}

TEST_CASE("texture: linear-mipmap-nearest filters bilinearly on level floor(LOD) alone", "[ops][texture][gradcheck]") {
  const int th = 16, tw = 16;
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  Tensor tex = random_input({th, tw, 2}, -1, 1, 70);
  // LOD 1.3 and 1.8: level 1, which a user stack of the box levels places as its first level.
  Tensor dx, dy;
  lod_derivatives({1.3, 1.8}, tw, &dx, &dy);
  const Tensor uv = sample_uv(2, layout, 1, 1, 71);
  TextureOptions nearest_level;
  nearest_level.filter = Filter::LinearMipmapNearest;
  const Tensor out = texture(tex, uv, nearest_level, dx, dy);
  const std::vector<Tensor> levels = box_levels(tex.detach());
  TextureOptions bilinear;
  const Tensor expected = texture(levels[0], uv, bilinear);
  const std::vector<double> a = out.to_vector(), b = expected.to_vector();
  for (std::size_t i = 0; i < a.size(); ++i) CHECK(a[i] == Approx(b[i]).margin(1e-14));
  // Gradients to the texels (through the box filter) and to uv; none to the derivatives.
  Tensor uv_in = uv.detach().set_requires_grad();
  require_gradcheck("texture linear-mipmap-nearest",
                    [&](const Inputs& in) { return texture(in[0], in[1], nearest_level, dx, dy); }, {tex, uv_in});
  Tensor dx_in = dx.detach().set_requires_grad();
  Tensor tex_in = tex.detach().set_requires_grad();
  backward(sum(texture(tex_in, uv, nearest_level, dx_in, dy)));
  CHECK(tex_in.grad().defined());
  if (dx_in.grad().defined())
    for (double g : dx_in.grad().to_vector()) CHECK(g == 0.0);
}

// ---- a texture per image (tex [B, Ht, Wt, C]) ----

namespace {

// Image b of a [B, ...] tensor as a new leaf [...]; image 0 for B = 1 (an input the images share).
Tensor image_of(const Tensor& t, std::int64_t b) {
  std::vector<std::int64_t> dims = t.shape().dims();
  const std::int64_t n = t.numel() / dims[0], at = dims[0] == 1 ? 0 : b * n;
  const std::vector<double> v = t.to_vector();
  dims.erase(dims.begin());
  return Tensor::from_values({v.begin() + at, v.begin() + at + n}, Shape(dims), t.dtype());
}

// A batched lookup: tex [T, Ht, Wt, C] (T = B or 1), uv, uv_dx, uv_dy [B, ..., 2],
// bias [B, ...], a user mip stack of [T, h_l, w_l, C] levels (optional) and
// the incoming gradient g [B, ..., C].
struct BatchedLookup {
  TextureOptions opt;
  Tensor tex, uv, dx, dy, bias, g;
  std::vector<Tensor> mip;
};

// Values, then the gradients of tex, uv, uv_dx, uv_dy, bias and each mip
// level: of one call (batched) or of one call per image, each with its own
// backward, per-image gradients side by side and a shared input's summed in
// image order (in its dtype).
std::vector<double> run_lookup(const BatchedLookup& in, bool batched) {
  const bool mipped = raster::mipmapped(in.opt.filter);
  std::vector<Tensor> inputs = {in.tex, in.uv, mipped ? in.dx : Tensor(), mipped ? in.dy : Tensor(),
                                mipped ? in.bias : Tensor()};
  inputs.insert(inputs.end(), in.mip.begin(), in.mip.end());
  const std::int64_t B = in.uv.size(0);
  auto lookup = [&](std::vector<Tensor>& x) {
    return texture(x[0], x[1], in.opt, x[2], x[3], x[4], std::vector<Tensor>(x.begin() + 5, x.end()));
  };
  std::vector<double> values;
  std::vector<std::vector<double>> grads(inputs.size());
  for (std::int64_t b = 0; b < (batched ? 1 : B); ++b) {
    std::vector<Tensor> x;
    for (const Tensor& t : inputs)
      x.push_back(!t.defined() ? Tensor() : (batched ? t.copy() : image_of(t, b)).set_requires_grad());
    const Tensor out = lookup(x);
    backward(out, batched ? in.g : image_of(in.g, b));
    for (double v : out.to_vector()) values.push_back(v);
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (!x[i].defined() || !x[i].grad().defined()) continue;
      const std::vector<double> g = x[i].grad().to_vector();
      if (b == 0 || inputs[i].size(0) != 1) {
        grads[i].insert(grads[i].end(), g.begin(), g.end());
        continue;
      }
      for (std::size_t k = 0; k < g.size(); ++k)
        grads[i][k] = in.tex.dtype() == DType::Float32 ? double(float(grads[i][k]) + float(g[k])) : grads[i][k] + g[k];
    }
  }
  for (const std::vector<double>& g : grads) values.insert(values.end(), g.begin(), g.end());
  return values;
}

BatchedLookup random_lookup(Filter filter, std::int64_t textures, bool user_mip, DType dtype) {
  constexpr std::int64_t B = 3, th = 12, tw = 16, C = 2;
  BatchedLookup in;
  in.opt.filter = filter;
  in.opt.wrap = Wrap::Mirror;
  in.tex = Tensor::uniform({textures, th, tw, C}, -1, 1, 101, dtype);
  in.uv = Tensor::uniform({B, 30, 40, 2}, -0.3, 1.3, 102, dtype);
  in.dx = Tensor::uniform({B, 30, 40, 2}, -0.4, 0.4, 103, dtype);
  in.dy = Tensor::uniform({B, 30, 40, 2}, -0.1, 0.1, 104, dtype);
  in.bias = Tensor::uniform({B, 30, 40}, -1, 1, 105, dtype);
  in.g = Tensor::uniform({B, 30, 40, C}, -1, 1, 106, dtype);
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  for (int l = 1; user_mip && l < layout.count(); ++l)
    in.mip.push_back(
        Tensor::uniform({textures, layout.levels[l].height, layout.levels[l].width, C}, -1, 1, 106 + l, dtype));
  return in;
}

// Footprints (uv_dx, uv_dy, [n, 2] each) of the given LODs for a base texture
// th x tw: the major axis along x in even samples and along y in odd ones, at
// random angles, the minor axis 0.1-0.6 of it.
void footprints(const std::vector<double>& lods, int th, int tw, unsigned seed, Tensor* dx, Tensor* dy) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0, 6.283), small(0.1, 0.6);
  std::vector<double> a, b;
  for (std::size_t i = 0; i < lods.size(); ++i) {
    const double t = angle(rng), major = std::pow(2.0, lods[i]) / tw, minor = major * small(rng);
    const double big[2] = {major * std::cos(t), major * std::sin(t) * tw / th};
    const double little[2] = {-minor * std::sin(t), minor * std::cos(t) * tw / th};
    for (int k = 0; k < 2; ++k) a.push_back(i % 2 == 0 ? big[k] : little[k]);
    for (int k = 0; k < 2; ++k) b.push_back(i % 2 == 0 ? little[k] : big[k]);
  }
  const std::int64_t n = static_cast<std::int64_t>(lods.size());
  *dx = Tensor::from_values(a, {n, 2}, DType::Float64);
  *dy = Tensor::from_values(b, {n, 2}, DType::Float64);
}

// [n, ...] tensors stacked into [B, n, ...].
Tensor stack(const std::vector<Tensor>& images) {
  std::vector<double> v;
  for (const Tensor& t : images)
    for (double x : t.to_vector()) v.push_back(x);
  std::vector<std::int64_t> dims = images[0].shape().dims();
  dims.insert(dims.begin(), static_cast<std::int64_t>(images.size()));
  return Tensor::from_values(v, Shape(dims), images[0].dtype());
}

}  // namespace

TEST_CASE("texture: with a texture per image every image's values and gradients equal a separate call's bit for "
          "bit, for 1, 2 and 8 threads",
          "[ops][texture][batch][determinism]") {
  struct Case {
    const char* name;
    Filter filter;
    bool user_mip;
  };
  for (const Case& c : {Case{"nearest", Filter::Nearest, false}, Case{"bilinear", Filter::Bilinear, false},
                        Case{"trilinear", Filter::Trilinear, false},
                        Case{"linear-mipmap-nearest", Filter::LinearMipmapNearest, false},
                        Case{"trilinear with a user mip stack", Filter::Trilinear, true}})
    for (std::int64_t textures : {3, 1})
      for (DType dtype : {DType::Float32, DType::Float64}) {
        INFO(c.name << ", " << textures << " texture(s), " << dtype_name(dtype));
        const BatchedLookup in = random_lookup(c.filter, textures, c.user_mip, dtype);
        const std::vector<double> separate = run_lookup(in, false);
        for (int threads : {1, 2, 8}) {
          INFO(threads << " threads");
          set_num_threads(threads);
          CHECK(run_lookup(in, true) == separate);
        }
        set_num_threads(0);
      }
}

TEST_CASE("texture: with a texture per image the gradients w.r.t. texels, uv, uv_dx, uv_dy and the bias match "
          "finite differences, also next to mip-level transitions",
          "[ops][texture][batch][gradcheck]") {
  const int th = 12, tw = 16;
  const raster::MipLayout layout = raster::mip_layout(th, tw);
  // LODs within 0.04 of the level transitions 1, 2 and 3 (on both sides) and
  // inside levels; the biases shift them by less than 0.01.
  const std::vector<double> lods = {0.96, 1.04, 1.97, 2.03, 2.96, 3.04, 0.4, 1.5, 2.6, 3.4};
  std::vector<Tensor> uv, dx, dy;
  for (unsigned b = 0; b < 2; ++b) {
    Tensor x, y;
    footprints(lods, th, tw, 80 + b, &x, &y);
    dx.push_back(x);
    dy.push_back(y);
    uv.push_back(sample_uv(static_cast<std::int64_t>(lods.size()), layout, 0, 4, 90 + b));
  }
  const std::vector<Tensor> varying = {stack(uv).set_requires_grad(), stack(dx).set_requires_grad(),
                                       stack(dy).set_requires_grad(), random_input({2, 10}, -0.01, 0.01, 95)};
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  SECTION("a texture per image, and one texture the images share") {
    for (std::int64_t textures : {2, 1}) {
      INFO(textures << " texture(s)");
      std::vector<Tensor> inputs = {random_input({textures, th, tw, 2}, -1, 1, 96)};
      inputs.insert(inputs.end(), varying.begin(), varying.end());
      require_gradcheck(textures == 2 ? "texture per image: tex, uv, uv_dx, uv_dy, bias"
                                      : "texture shared by 2 images: tex, uv, uv_dx, uv_dy, bias",
                        [&](const Inputs& in) { return texture(in[0], in[1], opt, in[2], in[3], in[4]); }, inputs);
    }
  }
  SECTION("with a user mip stack per image") {
    std::vector<Tensor> inputs = {random_input({2, th, tw, 2}, -1, 1, 97)};
    inputs.insert(inputs.end(), varying.begin(), varying.end());
    std::uint64_t seed = 98;
    for (int l = 1; l < layout.count(); ++l)
      inputs.push_back(random_input({2, layout.levels[l].height, layout.levels[l].width, 2}, -1, 1, seed++));
    require_gradcheck("texture per image, user mip stack",
                      [&](const Inputs& in) {
                        const std::vector<Tensor> mip(in.begin() + 5, in.end());
                        return texture(in[0], in[1], opt, in[2], in[3], in[4], mip);
                      },
                      inputs);
  }
}

TEST_CASE("texture: per-image textures whose batch size disagrees with uv's are refused, naming both arguments",
          "[ops][texture][batch][errors]") {
  const Tensor uv = Tensor::full({2, 5, 2}, 0.5);
  CHECK_THROWS_AS(texture(Tensor::ones({3, 4, 4, 3}), uv), ShapeError);
  CHECK_THROWS_WITH(texture(Tensor::ones({3, 4, 4, 3}), uv),
                    Catch::Contains("'tex' float32[3, 4, 4, 3]") && Catch::Contains("'uv' float32[2, 5, 2]"));
  CHECK_THROWS_WITH(texture(Tensor::ones({2, 4, 4, 3}), Tensor::full({2}, 0.5)),
                    Catch::Contains("'uv'") && Catch::Contains("[B, ..., 2]"));
  CHECK_THROWS_WITH(texture(Tensor::ones({2, 4, 4, 0}), uv), Catch::Contains("'tex'"));
  // A texture shared by the images: B = 1.
  CHECK(texture(Tensor::ones({1, 4, 4, 3}), uv).shape() == Shape{2, 5, 3});
  // A user mip stack follows tex's batch size.
  TextureOptions tri;
  tri.filter = Filter::Trilinear;
  const Tensor d = Tensor::full({2, 5, 2}, 0.1);
  const std::vector<Tensor> single_mip = {Tensor::ones({1, 2, 2, 3}), Tensor::ones({1, 1, 1, 3})};
  CHECK_THROWS_WITH(texture(Tensor::ones({2, 4, 4, 3}), uv, tri, d, d, {}, single_mip), Catch::Contains("mip[0]"));
  // A NaN texel of image 1 is named by its index in tex.
  Tensor bad = Tensor::ones({2, 4, 4, 3});
  bad.data<float>()[53] = std::nanf("");
  CHECK_THROWS_WITH(texture(bad, uv), Catch::Contains("tex[53]"));
}

TEST_CASE("texture: float64 uv at the ends of the double range samples finite values and gradients", "[ops][texture]") {
  // An audit's finding: u W - 0.5 overflowed to Inf for u near DBL_MAX, and
  // its fraction x - floor(x) = NaN made the bilinear sample and the texel and
  // uv gradients NaN (huge uv below the overflow were finite already).
  const double big = std::numeric_limits<double>::max();
  Tensor tex = Tensor::uniform({3, 5, 2}, 0, 1, 7, DType::Float64).set_requires_grad();
  Tensor uv = Tensor::from_values({big, 0.5, -big, 0.5, 0.5, big, 0.5, -big, big, -big, 0.25, 0.75}, {6, 2},
                                  DType::Float64)
                  .set_requires_grad();
  const Tensor d = Tensor::from_values(std::vector<double>(12, 0.01), {6, 2}, DType::Float64);
  for (Filter f : {Filter::Nearest, Filter::Bilinear, Filter::Trilinear, Filter::LinearMipmapNearest})
    for (Wrap w : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Zero}) {
      TextureOptions o;
      o.filter = f;
      o.wrap = w;
      const bool mipmapped = f == Filter::Trilinear || f == Filter::LinearMipmapNearest;
      const Tensor out = mipmapped ? texture(tex, uv, o, d, d) : texture(tex, uv, o);
      backward(sum(out * out));
      INFO("filter " << int(f) << ", wrap " << int(w));
      for (const Tensor& x : {out, tex.grad(), uv.grad()})
        for (double v : x.to_vector()) REQUIRE(std::isfinite(v));
      tex.zero_grad();
      uv.zero_grad();
    }
}
