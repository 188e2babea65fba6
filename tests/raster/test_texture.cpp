// Tests of the texture and mip-pyramid kernels: pyramid sizes and box
// averages, the pyramid adjoint as a transpose, addressing modes, hand values
// of nearest / bilinear / trilinear lookups, the uv orientation against an
// image file, the LOD rule and bad input.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/io/image_io.h"
#include "raster/mipmap.h"
#include "raster/temp_dir.h"
#include "raster/texture.h"
#include "raster/kernel_checks.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

// One lookup of a single-level (nearest / bilinear) texture.
std::vector<double> lookup(const std::vector<double>& tex, int h, int w, int c, double u, double v, Filter filter,
                           Wrap wrap) {
  TextureParams<double> p;
  p.tex = tex.data();
  p.layout = mip_layout(h, w, 0);
  p.channels = c;
  const double uv[2] = {u, v};
  p.uv = uv;
  p.num_samples = 1;
  p.filter = filter;
  p.wrap = wrap;
  std::vector<double> out(c);
  texture_forward(p, out.data());
  return out;
}

}  // namespace

TEST_CASE("mip layout halves each side with the floor rule down to 1 x 1", "[raster][texture]") {
  const MipLayout a = mip_layout(5, 8);
  REQUIRE(a.count() == 4);
  CHECK(a.levels[1].height == 2);
  CHECK(a.levels[1].width == 4);
  CHECK(a.levels[2].height == 1);
  CHECK(a.levels[2].width == 2);
  CHECK(a.levels[3].height == 1);
  CHECK(a.levels[3].width == 1);
  CHECK(a.levels[3].offset == 40 + 8 + 2);
  CHECK(a.total_texels == 51);
  CHECK(mip_layout(5, 8, 1).count() == 2);
  CHECK(mip_layout(5, 8, 0).count() == 1);
  CHECK(mip_layout(1, 1).count() == 1);
  CHECK(mip_layout(1024, 1024).count() == 11);
  CHECK_THROWS_AS(mip_layout(0, 4), ShapeError);
}

TEST_CASE("mip levels are box averages and odd sides fold their last texel into the last child", "[raster][texture]") {
  // 3 x 4, one channel: level 1 is 1 x 2, each child averaging a 3 x 2 block.
  const std::vector<double> base = {1, 2, 3, 4,  //
                                    5, 6, 7, 8,  //
                                    9, 10, 11, 12};
  const MipLayout layout = mip_layout(3, 4);
  REQUIRE(layout.count() == 3);
  std::vector<double> pyr(layout.total_texels - 12);
  mip_build(base.data(), 1, layout, pyr.data());
  CHECK(pyr[0] == Approx((1 + 2 + 5 + 6 + 9 + 10) / 6.0));
  CHECK(pyr[1] == Approx((3 + 4 + 7 + 8 + 11 + 12) / 6.0));
  CHECK(pyr[2] == Approx(6.5));  // the mean of everything
  // A constant texture stays constant on every level, odd sizes included.
  const MipLayout odd = mip_layout(7, 13);
  std::vector<float> flat(7 * 13 * 2, 0.25f), opyr((odd.total_texels - 91) * 2);
  mip_build(flat.data(), 2, odd, opyr.data());
  for (float x : opyr) CHECK(x == 0.25f);
}

TEST_CASE("mip backward is the transpose of mip build", "[raster][texture]") {
  for (auto hw : {std::pair<int, int>{8, 8}, {7, 12}, {1, 5}, {9, 3}}) {
    const int h = hw.first, w = hw.second, C = 2;
    INFO(h << " x " << w);
    const MipLayout layout = mip_layout(h, w);
    const std::int64_t base_n = std::int64_t(h) * w * C, all_n = layout.total_texels * C;
    const std::vector<double> x = random_vector(base_n, -1, 1, 3);
    const std::vector<double> g = random_vector(all_n, -1, 1, 4);
    // <g, build(x)> over all levels == <mip_backward(g), x>.
    std::vector<double> pyr(all_n - base_n);
    mip_build(x.data(), C, layout, pyr.data());
    double lhs = 0;
    for (std::int64_t i = 0; i < all_n; ++i) lhs += g[i] * (i < base_n ? x[i] : pyr[i - base_n]);
    std::vector<double> gb = g;
    mip_backward(C, layout, gb.data());
    double rhs = 0;
    for (std::int64_t i = 0; i < base_n; ++i) rhs += gb[i] * x[i];
    CHECK(lhs == Approx(rhs).epsilon(1e-12));
  }
}

TEST_CASE("mip backward in two steps, level 0 in parts of any size, gives the bits of mip backward rounded once",
          "[raster][texture]") {
  // texture_backward sums level 0 a piece at a time (raster/texture_backward.cpp).
  for (auto hw : {std::pair<int, int>{8, 8}, {7, 12}, {1, 5}, {9, 3}, {33, 17}}) {
    const int h = hw.first, w = hw.second, C = 3;
    INFO(h << " x " << w);
    const MipLayout layout = mip_layout(h, w);
    const std::int64_t base_texels = std::int64_t(h) * w, all_n = layout.total_texels * C;
    const std::vector<double> g = random_vector(all_n, -1, 1, 5);
    std::vector<double> whole = g;
    mip_backward(C, layout, whole.data());
    const std::vector<float> start(base_texels * C, 0.5f);  // the adjoint adds (+=) into grad_tex
    std::vector<float> want = start;
    for (std::int64_t k = 0; k < base_texels * C; ++k) want[k] += static_cast<float>(whole[k]);
    for (std::int64_t part : {std::int64_t(1), std::int64_t(5), std::int64_t(16), base_texels}) {
      INFO("parts of " << part << " texels");
      std::vector<double> levels(g.begin() + base_texels * C, g.end());
      mip_backward_levels(C, layout, levels.data());
      std::vector<float> got = start;
      for (std::int64_t first = 0; first < base_texels; first += part) {
        const std::int64_t last = std::min(base_texels, first + part);
        mip_backward_base(C, layout, levels.data(), first, last, g.data() + first * C, got.data());
      }
      CHECK(got == want);
      CHECK(std::equal(levels.begin(), levels.end(), whole.begin() + base_texels * C));  // levels 1.. as mip_backward left them
    }
  }
}

TEST_CASE("zero addressing reads texels outside the texture as 0 for nearest and bilinear", "[raster][texture]") {
  // 1 x 4 texture of ones: inside, every mode reads 1.
  const std::vector<double> ones = {1, 1, 1, 1};
  auto at = [&](double u, Filter f) { return lookup(ones, 1, 4, 1, u, 0.5, f, Wrap::Zero)[0]; };
  CHECK(at(0.5, Filter::Nearest) == 1);
  CHECK(at(-0.1, Filter::Nearest) == 0);
  CHECK(at(1.0, Filter::Nearest) == 0);
  CHECK(at(0.5, Filter::Bilinear) == 1);
  CHECK(at(0.0, Filter::Bilinear) == 0.5);    // x = -0.5: half on texel -1 (0), half on texel 0
  CHECK(at(1.0, Filter::Bilinear) == 0.5);    // x = 3.5: half on texel 3, half on texel 4 (0)
  CHECK(at(-0.125, Filter::Bilinear) == 0);   // x = -1: entirely outside
  CHECK(at(1.0 / 16, Filter::Bilinear) == 0.75);
}

TEST_CASE("nearest picks the texel under uv with repeat, clamp and mirror addressing", "[raster][texture]") {
  // 1 x 4 texture with values 0..3; v is irrelevant for a single row.
  const std::vector<double> tex = {0, 1, 2, 3};
  auto at = [&](double u, Wrap wrap) { return lookup(tex, 1, 4, 1, u, 0.5, Filter::Nearest, wrap)[0]; };
  CHECK(at(0.1, Wrap::Repeat) == 0);
  CHECK(at(0.3, Wrap::Repeat) == 1);
  CHECK(at(0.9, Wrap::Repeat) == 3);
  CHECK(at(1.1, Wrap::Repeat) == 0);
  CHECK(at(-0.1, Wrap::Repeat) == 3);
  CHECK(at(-2.6, Wrap::Repeat) == 1);
  CHECK(at(1.1, Wrap::Clamp) == 3);
  CHECK(at(-7.0, Wrap::Clamp) == 0);
  CHECK(at(1.1, Wrap::Mirror) == 3);   // texel 4 -> 3
  CHECK(at(1.3, Wrap::Mirror) == 2);   // texel 5 -> 2
  CHECK(at(-0.1, Wrap::Mirror) == 0);  // texel -1 -> 0
  CHECK(at(-0.3, Wrap::Mirror) == 1);  // texel -2 -> 1
  CHECK(at(2.1, Wrap::Mirror) == 0);   // texel 8 -> 0 (period 8)
}

TEST_CASE("bilinear reproduces texel centres, blends midpoints and blends across the repeat seam", "[raster][texture]") {
  // 2 x 3 texture (rows top to bottom), one channel.
  const std::vector<double> tex = {1, 2, 4,  //
                                   8, 16, 32};
  auto at = [&](double x, double y, Wrap wrap) {
    // Texel coordinates -> uv: u = (x + 0.5) / W, v = 1 - (y + 0.5) / H.
    return lookup(tex, 2, 3, 1, (x + 0.5) / 3, 1 - (y + 0.5) / 2, Filter::Bilinear, wrap)[0];
  };
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror}) {
    CHECK(at(0, 0, wrap) == Approx(1));
    CHECK(at(2, 1, wrap) == Approx(32));
    CHECK(at(0.5, 0, wrap) == Approx(1.5));
    CHECK(at(1, 0.25, wrap) == Approx(0.75 * 2 + 0.25 * 16));
  }
  // Half-way between the last and the first column.
  CHECK(at(2.5, 0, Wrap::Repeat) == Approx(2.5));
  CHECK(at(-0.5, 0, Wrap::Repeat) == Approx(2.5));
  CHECK(at(2.5, 0, Wrap::Clamp) == Approx(4));
  CHECK(at(-0.5, 0, Wrap::Mirror) == Approx(1));
  CHECK(at(-1.5, 0, Wrap::Mirror) == Approx(1.5));
}

TEST_CASE("uv (0, 1) is the top-left of an image read from a file", "[raster][texture]") {
  gr::testing::TempDir dir;
  // 2 x 3 RGB: top-left red, top-right green, bottom-left blue, rest white.
  std::vector<float> px(2 * 3 * 3, 1.0f);
  auto set = [&](int row, int col, float r, float g, float b) {
    float* p = &px[(row * 3 + col) * 3];
    p[0] = r;
    p[1] = g;
    p[2] = b;
  };
  set(0, 0, 1, 0, 0);
  set(0, 2, 0, 1, 0);
  set(1, 0, 0, 0, 1);
  const std::string path = dir.file("corners.png");
  write_png(path, Tensor::from_vector<float>(px, {2, 3, 3}));
  Tensor img = read_image(path, 3);
  REQUIRE(img.shape() == Shape{2, 3, 3});
  TextureParams<float> p;
  p.tex = img.data<float>();
  p.layout = mip_layout(2, 3, 0);
  p.channels = 3;
  // Texel centres: top-left, top-right, bottom-left (v up).
  const float uv[6] = {0.5f / 3, 1 - 0.5f / 2, 2.5f / 3, 1 - 0.5f / 2, 0.5f / 3, 0.5f / 2};
  p.uv = uv;
  p.num_samples = 3;
  for (Filter f : {Filter::Nearest, Filter::Bilinear}) {
    p.filter = f;
    std::vector<float> out(9);
    texture_forward(p, out.data());
    CHECK(out[0] == Approx(1));
    CHECK(out[1] == Approx(0).margin(1e-6));
    CHECK(out[2] == Approx(0).margin(1e-6));
    CHECK(out[3] == Approx(0).margin(1e-6));
    CHECK(out[4] == Approx(1));
    CHECK(out[6] == Approx(0).margin(1e-6));
    CHECK(out[8] == Approx(1));
  }
}

TEST_CASE("trilinear blends the two levels around the LOD", "[raster][texture]") {
  // 4 x 4, one channel; level 1 is 2 x 2 block means, level 2 the overall mean.
  const std::vector<double> tex = random_vector(16, 0, 1, 9);
  const MipLayout layout = mip_layout(4, 4);
  std::vector<double> pyr(layout.total_texels - 16);
  mip_build(tex.data(), 1, layout, pyr.data());
  const double top_left = (tex[0] + tex[1] + tex[4] + tex[5]) / 4, mean = pyr[4];
  TextureParams<double> p;
  p.tex = tex.data();
  p.pyramid = pyr.data();
  p.layout = layout;
  p.channels = 1;
  p.filter = Filter::Trilinear;
  // uv at the centre of level 1's top-left texel; footprint 2^1.3 texels.
  const double uv[2] = {0.25, 0.75}, dx[2] = {std::pow(2.0, 1.3) / 4, 0}, dy[2] = {0, 0.01};
  p.uv = uv;
  p.uv_dx = dx;
  p.uv_dy = dy;
  p.num_samples = 1;
  double out = 0;
  texture_forward(p, &out);
  CHECK(out == Approx(0.7 * top_left + 0.3 * mean).epsilon(1e-12));
  // Beyond the last level: the 1 x 1 level alone.
  const double far_dx[2] = {100, 0};
  p.uv_dx = far_dx;
  texture_forward(p, &out);
  CHECK(out == Approx(mean).epsilon(1e-12));
}

TEST_CASE("LOD is log2 of the larger footprint in base texels, clamped to the levels", "[raster][texture]") {
  CHECK(texture_lod(4.0 / 64, 0, 0, 1.0 / 32, 64, 32, 7) == Approx(2));
  CHECK(texture_lod(0, 0, 0, 8.0 / 32, 64, 32, 7) == Approx(3));
  CHECK(texture_lod(3.0 / 64, 4.0 / 32, 0, 0, 64, 32, 7) == Approx(std::log2(5.0)));
  CHECK(texture_lod(1e-9, 0, 0, 0, 64, 32, 7) == 0);
  CHECK(texture_lod(0, 0, 0, 0, 64, 32, 7) == 0);
  CHECK(texture_lod(1e9, 0, 0, 0, 64, 32, 7) == 6);
  CHECK(texture_lod(std::nan(""), 0, 0, 0, 64, 32, 7) == 0);
}

TEST_CASE("texture kernels reject NaN uv and stay in bounds for huge uv", "[raster][texture][errors]") {
  const std::vector<double> tex = random_vector(4 * 5 * 2, 0, 1, 5);
  TextureParams<double> p;
  p.tex = tex.data();
  p.layout = mip_layout(4, 5, 0);
  p.channels = 2;
  p.num_samples = 3;
  const double bad[6] = {0.5, 0.5, 0.1, std::numeric_limits<double>::quiet_NaN(), 0, 0};
  p.uv = bad;
  std::vector<double> out(6);
  CHECK_THROWS_WITH(texture_forward(p, out.data()), Catch::Contains("uv[3]"));
  const double huge[6] = {1e300, -1e300, -3e18, 7e15, 1e-300, -1e17};
  p.uv = huge;
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror})
    for (Filter f : {Filter::Nearest, Filter::Bilinear}) {
      p.wrap = wrap;
      p.filter = f;
      texture_forward(p, out.data());
      for (double x : out) CHECK(std::isfinite(x));
    }
  p.filter = Filter::Trilinear;  // without derivatives
  p.uv = bad + 0;
  CHECK_THROWS_AS(texture_forward(p, out.data()), ValueError);
}

TEST_CASE("major-axis LOD is log2 of the footprint ellipse's major axis", "[raster][texture]") {
  const LodRule major = LodRule::MajorAxis;
  // Footprints along the axes: the same as the isotropic rule.
  CHECK(texture_lod(4.0 / 64, 0, 0, 1.0 / 32, 64, 32, 7, 0.0, major) == Approx(2));
  CHECK(texture_lod(0, 0, 0, 8.0 / 32, 64, 32, 7, 0.0, major) == Approx(3));
  // a = b = (2, 0) texels: A = B = C = 4, so the major axis^2 is 8 (isotropic: 4).
  CHECK(texture_lod(2.0 / 64, 0, 2.0 / 64, 0, 64, 32, 7, 0.0, major) == Approx(1.5));
  CHECK(texture_lod(2.0 / 64, 0, 2.0 / 64, 0, 64, 32, 7) == Approx(1.0));
  // a = (3, 0), b = (0, 4)... and a sheared pair a = (2, 1), b = (1, 2): A = B = 5, C = 4, major^2 = 9.
  CHECK(texture_lod(2.0 / 64, 1.0 / 32, 1.0 / 64, 2.0 / 32, 64, 32, 7, 0.0, major) == Approx(0.5 * std::log2(9.0)));
  CHECK(texture_lod(0, 0, 0, 0, 64, 32, 7, 0.0, major) == 0);
  CHECK(texture_lod(1e9, 0, 0, 0, 64, 32, 7, 0.5, major) == 6);
}

TEST_CASE("the bilinear adjoint takes the same uv gradient from the forward's saved Jacobian as from the texels",
          "[raster][texture]") {
  const int h = 9, w = 13, c = 3;
  const std::int64_t S = 500;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0), wide(-0.3, 1.3);
  std::vector<double> tex(h * w * c), uv(2 * S), g(S * c);
  for (double& x : tex) x = unit(rng);
  for (double& x : uv) x = wide(rng);
  for (double& x : g) x = 2 * unit(rng) - 1;
  auto params = [&](Filter filter, Wrap wrap) {
    TextureParams<double> p;
    p.tex = tex.data();
    p.layout = mip_layout(h, w, 0);
    p.channels = c;
    p.uv = uv.data();
    p.num_samples = S;
    p.filter = filter;
    p.wrap = wrap;
    return p;
  };
  for (Wrap wrap : {Wrap::Repeat, Wrap::Clamp, Wrap::Mirror, Wrap::Zero}) {
    const TextureParams<double> p = params(Filter::Bilinear, wrap);
    std::vector<double> out(S * c), out_j(S * c), jac(S * 2 * c);
    texture_forward(p, out.data());
    texture_forward(p, out_j.data(), jac.data());
    CHECK(out == out_j);  // saving the Jacobian leaves the values alone
    std::vector<double> gt(tex.size()), guv(uv.size()), gt_j(tex.size()), guv_j(uv.size());
    TextureGrads<double> from_texels{gt.data(), guv.data()}, from_jacobian{gt_j.data(), guv_j.data()};
    texture_backward(p, g.data(), from_texels);
    texture_backward(p, g.data(), from_jacobian, jac.data());
    CHECK(gt == gt_j);
    for (std::size_t i = 0; i < uv.size(); ++i) REQUIRE(guv_j[i] == Approx(guv[i]).epsilon(1e-12).margin(1e-12));
  }
  // The Jacobian is the bilinear filter's only.
  std::vector<double> out(S * c), jac(S * 2 * c);
  const TextureParams<double> p = params(Filter::Nearest, Wrap::Repeat);
  CHECK_THROWS_WITH(texture_forward(p, out.data(), jac.data()), Catch::Contains("bilinear"));
}
