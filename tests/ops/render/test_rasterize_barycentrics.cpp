// rasterize's G-buffer values (ops/render/rasterize.h): the perspective-correct
// weights (u, v) of vertices 0 and 1, z/w and the derivative buffer db, against
// an independent evaluation (the 3 x 3 linear system of the pixel's ray, no
// homogeneous cross products), finite differences across pixels, and float64
// gradient checks w.r.t. clip on random and hard triangles.
#include <catch2/catch.hpp>

#include <cmath>

#include "ops/clip_scenes.h"
#include "ops/pixel_ray.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::ndc_x;
using gr::testing::ndc_y;
using gr::testing::pixel_ray;
using gr::testing::PixelRay;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

constexpr int W = 24, H = 20;

RasterizeOptions with_derivatives(int width, int height) {
  RasterizeOptions o{width, height};
  o.derivatives = true;
  return o;
}

// Worst |difference| between the G-buffer and the reference over covered
// pixels: uv, depth, and db against central differences of the reference.
struct Errors {
  double uv = 0, depth = 0, db = 0;
  int covered = 0;
};
Errors compare_with_reference(const Tensor& clip, const Tensor& tris, const GBuffer& gb, int width, int height) {
  const std::vector<double> c = clip.to_vector();
  const std::vector<std::int32_t> t(tris.data<std::int32_t>(), tris.data<std::int32_t>() + tris.numel());
  const std::vector<double> uv = gb.uv.to_vector(), depth = gb.depth.to_vector(), db = gb.db.to_vector(),
                            id = gb.tri_id.to_vector();
  Errors e;
  const double h = 1e-4;  // pixels
  for (int py = 0; py < height; ++py)
    for (int px = 0; px < width; ++px) {
      const int p = py * width + px;
      if (id[p] == 0) continue;
      ++e.covered;
      const int tri = static_cast<int>(id[p]) - 1;
      const double x = px + 0.5, y = py + 0.5;
      const PixelRay r = pixel_ray(c, t, tri, ndc_x(x, width), ndc_y(y, height));
      e.uv = std::max({e.uv, std::abs(uv[2 * p] - r.b[0]), std::abs(uv[2 * p + 1] - r.b[1])});
      e.depth = std::max(e.depth, std::abs(depth[p] - r.zw));
      const PixelRay xp = pixel_ray(c, t, tri, ndc_x(x + h, width), ndc_y(y, height));
      const PixelRay xm = pixel_ray(c, t, tri, ndc_x(x - h, width), ndc_y(y, height));
      const PixelRay yp = pixel_ray(c, t, tri, ndc_x(x, width), ndc_y(y + h, height));
      const PixelRay ym = pixel_ray(c, t, tri, ndc_x(x, width), ndc_y(y - h, height));
      for (int k = 0; k < 2; ++k) {
        const double dx = (xp.b[k] - xm.b[k]) / (2 * h), dy = (yp.b[k] - ym.b[k]) / (2 * h);
        e.db = std::max({e.db, std::abs(db[4 * p + 2 * k] - dx), std::abs(db[4 * p + 2 * k + 1] - dy)});
      }
    }
  return e;
}

// Hard triangles, one per row group of `tris`: a vertex behind the eye (the
// triangle crosses w = 0 and the near plane), a sliver, and a floor seen at a
// grazing angle (w from 0.6 to 8).
Tensor hard_clip() {
  return Tensor::from_values({-0.6, -0.6, 0.0, 1.0, 0.7, -0.5, 0.1, 1.0, 0.1, 0.4, -2.0, -0.5,  //
                              -0.9, 0.5, 0.0, 1.0, 0.9, 0.53, 0.1, 1.0, 0.9, 0.6, 0.1, 1.0,     //
                              -0.5, -0.3, 0.4, 0.6, 0.5, -0.3, 0.4, 0.6, 0.05, -0.3, 7.9, 8.0},
                             {9, 4}, DType::Float64);
}
Tensor tris_of(int n) {
  std::vector<std::int32_t> t;
  for (int k = 0; k < 3 * n; ++k) t.push_back(k);
  return Tensor::from_vector<std::int32_t>(t, {n, 3});
}

}  // namespace

TEST_CASE("rasterize barycentrics: uv, depth and db equal the solution of each pixel ray's linear system",
          "[ops][rasterize][barycentrics]") {
  const Tensor tris = gr::testing::two_triangles();
  const Tensor clip = gr::testing::two_triangles_clip();
  const GBuffer gb = rasterize(clip, tris, with_derivatives(W, H));
  const Errors e = compare_with_reference(clip, tris, gb, W, H);
  CHECK(e.covered > 100);
  CHECK(e.uv < 1e-13);
  CHECK(e.depth < 1e-13);
  CHECK(e.db < 1e-8);  // central differences with h = 1e-4 pixel
  for (int k = 0; k < 3; ++k) {
    INFO("hard triangle " << k);
    const Tensor one = slice(hard_clip(), 0, 3 * k, 3 * k + 3);
    const GBuffer g = rasterize(one, tris_of(1), with_derivatives(W, H));
    const Errors h = compare_with_reference(one, tris_of(1), g, W, H);
    CHECK(h.covered > 3);
    CHECK(h.uv < 1e-12);
    CHECK(h.depth < 1e-12);
    CHECK(h.db < 1e-7);
  }
  // Background: uv and db zero, depth the far plane.
  const std::vector<double> uv = gb.uv.to_vector(), db = gb.db.to_vector(), depth = gb.depth.to_vector(),
                            id = gb.tri_id.to_vector();
  for (std::size_t p = 0; p < id.size(); ++p)
    if (id[p] == 0) {
      CHECK((uv[2 * p] == 0 && uv[2 * p + 1] == 0 && depth[p] == raster::kBackgroundDepth));
      CHECK((db[4 * p] == 0 && db[4 * p + 1] == 0 && db[4 * p + 2] == 0 && db[4 * p + 3] == 0));
    }
}

TEST_CASE("rasterize barycentrics: on an affine triangle db is the difference between neighbouring pixels",
          "[ops][rasterize][barycentrics]") {
  // w = 1 everywhere: barycentrics are affine in screen space.
  const Tensor clip = Tensor::from_values({-0.9, -0.8, 0.1, 1, 0.85, -0.7, 0.2, 1, -0.2, 0.9, 0.3, 1}, {3, 4},
                                          DType::Float64);
  const GBuffer gb = rasterize(clip, tris_of(1), with_derivatives(W, H));
  const std::vector<double> uv = gb.uv.to_vector(), db = gb.db.to_vector(), id = gb.tri_id.to_vector();
  int checked = 0;
  for (int y = 0; y + 1 < H; ++y)
    for (int x = 0; x + 1 < W; ++x) {
      const int p = y * W + x, right = p + 1, below = p + W;
      if (!id[p] || !id[right] || !id[below]) continue;
      for (int k = 0; k < 2; ++k) {
        CHECK(uv[2 * right + k] - uv[2 * p + k] == Approx(db[4 * p + 2 * k]).margin(1e-12));
        CHECK(uv[2 * below + k] - uv[2 * p + k] == Approx(db[4 * p + 2 * k + 1]).margin(1e-12));
      }
      ++checked;
    }
  CHECK(checked > 50);
}

TEST_CASE("rasterize barycentrics: uv, depth and db pass a float64 gradcheck w.r.t. clip, random and hard triangles",
          "[ops][rasterize][barycentrics][gradcheck]") {
  const Tensor tris = gr::testing::two_triangles();
  auto all = [](const Tensor& triangles) {
    return [triangles](const Inputs& in) {
      const GBuffer g = rasterize(in[0], triangles, with_derivatives(W, H));
      return concat({g.uv, reshape(g.depth, {H, W, 1}), g.db}, 2);
    };
  };
  // Coverage stays fixed for steps of 2 eps (no pixel centre that close to an edge).
  require_gradcheck("rasterize uv, depth, db", all(tris), {gr::testing::two_triangles_clip().set_requires_grad()},
                    GradcheckOptions{1e-6});
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    // Random triangles in front of the eye.
    Tensor clip = Tensor::uniform({6, 4}, -0.9, 0.9, seed, DType::Float64);
    double* c = clip.data<double>();
    for (int v = 0; v < 6; ++v) c[4 * v + 3] = 0.7 + 0.25 * (v % 3) + 0.1 * c[4 * v + 2];
    clip.set_requires_grad();
    require_gradcheck("rasterize uv, depth, db (random " + std::to_string(seed) + ")", all(tris), {clip},
                      GradcheckOptions{1e-6});
  }
  for (int k = 0; k < 3; ++k) {
    INFO("hard triangle " << k << " (near-plane crossing, sliver, grazing)");
    Tensor one = slice(hard_clip(), 0, 3 * k, 3 * k + 3).copy().set_requires_grad();
    GradcheckOptions opt;
    opt.eps = 1e-7;  // small steps: the sliver's and the grazing floor's coverage must not change
    opt.rtol = 1e-5;
    require_gradcheck("rasterize uv, depth, db (hard " + std::to_string(k) + ")", all(tris_of(1)), {one}, opt);
  }
}

TEST_CASE("rasterize barycentrics: interpolate_with_derivatives gives db's blend and is differentiable",
          "[ops][interpolate][barycentrics][gradcheck]") {
  const Tensor tris = gr::testing::two_triangles();
  const Tensor clip = gr::testing::two_triangles_clip();
  const GBuffer gb = rasterize(clip, tris, with_derivatives(W, H));
  // One-hot attributes of vertices 0 and 1: the values are uv, the derivatives db.
  std::vector<double> onehot;
  for (int v = 0; v < 6; ++v) onehot.push_back(v % 3 == 0), onehot.push_back(v % 3 == 1);
  const InterpolatedWithDerivatives d =
      interpolate_with_derivatives(Tensor::from_values(onehot, {6, 2}, DType::Float64), gb, tris);
  CHECK(d.values.to_vector() == gb.uv.to_vector());
  const std::vector<double> db = gb.db.to_vector(), dx = d.d_dx.to_vector(), dy = d.d_dy.to_vector();
  for (std::size_t p = 0; p < db.size() / 4; ++p)
    for (int k = 0; k < 2; ++k) {
      CHECK(dx[2 * p + k] == Approx(db[4 * p + 2 * k]).margin(1e-15));
      CHECK(dy[2 * p + k] == Approx(db[4 * p + 2 * k + 1]).margin(1e-15));
    }
  // Only channel 2 of three: d_dx, d_dy [H, W, 1].
  InterpolateOptions only;
  only.diff_attrs = {2};
  Tensor attr = gr::testing::random_input({6, 3}, -1, 1, 4);
  const InterpolatedWithDerivatives one = interpolate_with_derivatives(attr.detach(), gb, tris, only);
  CHECK(one.d_dx.shape() == Shape{H, W, 1});
  // Gradients w.r.t. the attributes and (through rasterize) clip.
  Tensor c = clip.copy().set_requires_grad();
  auto f = [&](const Inputs& in) {
    const GBuffer g = rasterize(in[0], tris, with_derivatives(W, H));
    const InterpolatedWithDerivatives r = interpolate_with_derivatives(in[1], g, tris, only);
    return concat({r.values, r.d_dx, r.d_dy}, 2);
  };
  require_gradcheck("interpolate_with_derivatives (clip, attributes)", f, {c, attr}, GradcheckOptions{1e-6});
}

TEST_CASE("rasterize barycentrics: a texture's level of detail is differentiable back to the clip positions",
          "[ops][rasterize][barycentrics][texture][gradcheck]") {
  const Tensor tris = gr::testing::two_triangles();
  Tensor clip = gr::testing::two_triangles_clip().copy().set_requires_grad();
  // uv attributes spanning several texels per pixel: LODs inside the chain.
  const Tensor uvs = Tensor::from_values({0.1, 0.2, 3.1, 0.4, 0.7, 2.9, 0.2, 0.1, 2.8, 0.7, 1.1, 3.3}, {6, 2},
                                         DType::Float64);
  const Tensor tex = Tensor::uniform({32, 32, 1}, 0, 1, 5, DType::Float64);
  TextureOptions opt;
  opt.filter = Filter::Trilinear;
  auto f = [&](const Inputs& in) {
    const GBuffer g = rasterize(in[0], tris, with_derivatives(W, H));
    const InterpolatedWithDerivatives uv = interpolate_with_derivatives(uvs, g, tris);
    return texture(tex, uv.values, opt, uv.d_dx, uv.d_dy);
  };
  GradcheckOptions g;
  g.eps = 1e-6;  // small steps: stay inside the bilinear cells and the LOD's level
  require_gradcheck("texture lod through rasterize's db", f, {clip}, g);
}

TEST_CASE("rasterize barycentrics: derivatives without db or of a missing channel are refused by name",
          "[ops][rasterize][barycentrics][errors]") {
  const Tensor clip = gr::testing::two_triangles_clip(), tris = gr::testing::two_triangles();
  const Tensor attr = Tensor::zeros({6, 2}, DType::Float64);
  CHECK_THROWS_WITH(interpolate_with_derivatives(attr, rasterize(clip, tris, {W, H}), tris),
                    Catch::Contains("gbuffer.db") && Catch::Contains("derivatives"));
  InterpolateOptions bad;
  bad.diff_attrs = {2};
  CHECK_THROWS_AS(interpolate_with_derivatives(attr, rasterize(clip, tris, with_derivatives(W, H)), tris, bad),
                  IndexError);
  CHECK_THROWS_WITH(interpolate_with_derivatives(attr, rasterize(clip, tris, with_derivatives(W, H)), tris, bad),
                    Catch::Contains("diff_attrs"));
}
