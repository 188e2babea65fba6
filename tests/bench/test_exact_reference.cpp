// The exact box-filtered reference (bench/exact_reference/): analytic
// coverage and visibility, the perspective-correct integral, smooth finite
// differences, and agreement with the library's supersampled render.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "bench/exact_reference/exact_reference.h"
#include "bench/exact_reference/quadrature.h"
#include "ops/ops.h"
#include "ops/render/resample.h"

namespace gr {
namespace {

using bench::exact_box_filtered;
using bench::ExactImage;

// A vertex given in screen space: pixel position, z_ndc and w.
struct ScreenVertex {
  double x, y, z, w;
};

// Clip coordinates whose projection is the given screen vertex (the
// rasterizer's viewport: xs = W/2 (1 + x/w), ys = H/2 (1 - y/w)).
Tensor clip_of(const std::vector<ScreenVertex>& vertices, int width, int height) {
  std::vector<double> c;
  for (const ScreenVertex& v : vertices) {
    c.push_back((2 * v.x / width - 1) * v.w);
    c.push_back((1 - 2 * v.y / height) * v.w);
    c.push_back(v.z * v.w);
    c.push_back(v.w);
  }
  return Tensor::from_values(c, {static_cast<std::int64_t>(vertices.size()), 4}, DType::Float64);
}

Tensor tris(const std::vector<std::int32_t>& indices) {
  return Tensor::from_vector(indices, {static_cast<std::int64_t>(indices.size() / 3), 3});
}

Tensor column(const std::vector<double>& values) {
  return Tensor::from_values(values, {static_cast<std::int64_t>(values.size()), 1}, DType::Float64);
}

Tensor scalar_background(double value) { return Tensor::from_values({value}, {1}, DType::Float64); }

double at(const Tensor& t, int y, int x, int c = 0) {
  const std::int64_t w = t.size(1), channels = t.rank() == 3 ? t.size(2) : 1;
  return t.data<double>()[(y * w + x) * channels + c];
}

// Area of [x0, x1] x [y0, y1] inside pixel (px, py).
double box_in_pixel(double x0, double y0, double x1, double y1, int px, int py) {
  const double w = std::min(x1, px + 1.0) - std::max(x0, double(px));
  const double h = std::min(y1, py + 1.0) - std::max(y0, double(py));
  return w > 0 && h > 0 ? w * h : 0.0;
}

// Two triangles making the axis-aligned quad [x0, x1] x [y0, y1] at depth z.
void add_quad(std::vector<ScreenVertex>& v, std::vector<std::int32_t>& t, double x0, double y0, double x1, double y1,
              double z, double w = 1) {
  const auto base = static_cast<std::int32_t>(v.size());
  for (const auto& p : {std::array<double, 2>{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}) v.push_back({p[0], p[1], z, w});
  for (int k : {0, 1, 2, 0, 2, 3}) t.push_back(base + k);
}

TEST_CASE("exact reference: a half-plane edge through a pixel covers exactly the area on its side", "[exact_reference]") {
  // Edge from (1.25, -10) to (1.75, 14): x(y) = 1.25 + (y + 10) / 48; the
  // covered part of pixel column 1 is 2 - x(py + 0.5) (the edge is affine in y).
  const int size = 4;
  for (double w : {1.0, 3.5}) {
    const Tensor clip = clip_of({{1.25, -10, 0.2, w}, {1.75, 14, 0.2, w}, {20, 2, 0.2, w}}, size, size);
    const ExactImage r = exact_box_filtered(clip, tris({0, 1, 2}), column({0.8, 0.8, 0.8}), size, size,
                                            scalar_background(0.1));
    for (int py = 0; py < size; ++py) {
      const double expected = 2 - (1.25 + (py + 0.5 + 10) / 48);
      CHECK(at(r.coverage, py, 1) == Approx(expected).margin(1e-14));
      CHECK(at(r.image, py, 1) == Approx(0.8 * expected + 0.1 * (1 - expected)).margin(1e-14));
      CHECK(at(r.coverage, py, 0) == 0.0);
      CHECK(at(r.coverage, py, 2) == Approx(1.0).margin(1e-14));
    }
  }
}

TEST_CASE("exact reference: of two overlapping squares the nearer one hides the other, coplanar ones by index",
          "[exact_reference]") {
  const int size = 4;
  const double a[4] = {0.5, 0.5, 2.5, 2.5}, b[4] = {1.25, 1.5, 3.75, 3.5};
  for (const auto& [za, zb, a_wins] : {std::array<double, 3>{0.2, -0.3, 0}, {-0.3, 0.2, 1}, {0.4, 0.4, 1}}) {
    std::vector<ScreenVertex> v;
    std::vector<std::int32_t> t;
    add_quad(v, t, a[0], a[1], a[2], a[3], za, 2.0);  // triangles 0, 1: the smaller indices
    add_quad(v, t, b[0], b[1], b[2], b[3], zb, 0.7);
    const ExactImage r = exact_box_filtered(clip_of(v, size, size), tris(t),
                                            column({1, 1, 1, 1, 2, 2, 2, 2}), size, size, scalar_background(0));
    for (int py = 0; py < size; ++py)
      for (int px = 0; px < size; ++px) {
        const double area_a = box_in_pixel(a[0], a[1], a[2], a[3], px, py);
        const double area_b = box_in_pixel(b[0], b[1], b[2], b[3], px, py);
        const double both = box_in_pixel(b[0], b[1], a[2], a[3], px, py);
        const double seen_a = a_wins ? area_a : area_a - both, seen_b = a_wins ? area_b - both : area_b;
        INFO("pixel " << px << ", " << py << ", a wins " << a_wins);
        CHECK(at(r.coverage, py, px) == Approx(seen_a + seen_b).margin(1e-13));
        CHECK(at(r.image, py, px) == Approx(seen_a + 2 * seen_b).margin(1e-13));
      }
  }
}

TEST_CASE("exact reference: two planes intersecting along a known line each show on their side of it",
          "[exact_reference]") {
  // z1 - z2 = 0.1 (x - 2.3 - 0.1 (y - 2)): surface 1 is nearer left of the
  // line x = 2.3 + 0.1 (y - 2), which stays inside pixel column 2. Different w
  // per vertex leave the screen geometry and depths unchanged.
  const int size = 4;
  const auto z1 = [](double x, double y) { return 0.3 + 0.05 * (x - 2.3 - 0.1 * (y - 2)); };
  const auto z2 = [](double x, double y) { return 0.3 - 0.05 * (x - 2.3 - 0.1 * (y - 2)); };
  std::vector<ScreenVertex> v;
  const double corners[4][2] = {{-1, -1}, {5, -1}, {5, 5}, {-1, 5}};
  for (int k = 0; k < 4; ++k) v.push_back({corners[k][0], corners[k][1], z1(corners[k][0], corners[k][1]), 1.0 + k});
  for (int k = 0; k < 4; ++k) v.push_back({corners[k][0], corners[k][1], z2(corners[k][0], corners[k][1]), 3.0 - 0.5 * k});
  const ExactImage r = exact_box_filtered(clip_of(v, size, size), tris({0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7}),
                                          column({1, 1, 1, 1, 0, 0, 0, 0}), size, size, scalar_background(0.5));
  for (int py = 0; py < size; ++py) {
    const double left = 2.3 + 0.1 * (py + 0.5 - 2) - 2;  // area of surface 1 in pixel (2, py)
    CHECK(at(r.image, py, 2) == Approx(left).margin(1e-13));
    CHECK(at(r.image, py, 1) == Approx(1.0).margin(1e-13));
    CHECK(at(r.image, py, 3) == Approx(0.0).margin(1e-13));
    CHECK(at(r.coverage, py, 2) == Approx(1.0).margin(1e-13));
  }
}

TEST_CASE("exact reference: the near and far planes cut a surface along z_ndc = -1 and z_ndc = 1",
          "[exact_reference]") {
  // z_ndc = 0.4 (x - 2.3 - 0.1 (y - 2)) - 1 on a quad over the whole 8 x 4
  // image: the near plane cuts it along x = 2.3 + 0.1 (y - 2) (pixel column 2)
  // and the far plane along x = 7.3 + 0.1 (y - 2) (column 7), as the rasterizer
  // clips -1 <= z_ndc <= 1 per pixel.
  const int width = 8, height = 4;
  const auto z = [](double x, double y) { return 0.4 * (x - 2.3 - 0.1 * (y - 2)) - 1; };
  std::vector<ScreenVertex> v;
  const double corners[4][2] = {{-1, -1}, {9, -1}, {9, 5}, {-1, 5}};
  for (int k = 0; k < 4; ++k) v.push_back({corners[k][0], corners[k][1], z(corners[k][0], corners[k][1]), 0.5 + k});
  const ExactImage r = exact_box_filtered(clip_of(v, width, height), tris({0, 1, 2, 0, 2, 3}), column({1, 1, 1, 1}),
                                          width, height, scalar_background(0));
  for (int py = 0; py < height; ++py) {
    const double shift = 0.1 * (py + 0.5 - 2);
    CHECK(at(r.coverage, py, 1) == 0.0);
    CHECK(at(r.coverage, py, 2) == Approx(3 - (2.3 + shift)).margin(1e-13));
    CHECK(at(r.coverage, py, 5) == Approx(1.0).margin(1e-13));
    CHECK(at(r.coverage, py, 7) == Approx(7.3 + shift - 7).margin(1e-13));
  }
}

TEST_CASE("exact reference: the perspective-correct attribute integral matches a fine tensor Gauss rule",
          "[exact_reference]") {
  // One strongly perspective triangle (w from 0.3 to 4) over a 4 x 4 image.
  // Inside it the attribute is (sum a_k b_k / w_k) / (sum b_k / w_k) with
  // screen barycentrics b; on a pixel wholly inside, a 40 x 40 Gauss-Legendre
  // product rule of that formula is exact to rounding.
  const int size = 4;
  const ScreenVertex p[3] = {{-0.5, -0.5, 0.1, 0.3}, {9.0, 0.2, 0.5, 4.0}, {0.1, 9.0, 0.3, 1.5}};
  const double attr[3] = {0.2, 3.0, -1.0};
  const Tensor clip = clip_of({p[0], p[1], p[2]}, size, size);
  const ExactImage r8 = exact_box_filtered(clip, tris({0, 1, 2}), column({attr[0], attr[1], attr[2]}), size, size,
                                           scalar_background(0));
  bench::ExactReferenceOptions order16;
  order16.quadrature_order = 16;
  const ExactImage r16 = exact_box_filtered(clip, tris({0, 1, 2}), column({attr[0], attr[1], attr[2]}), size, size,
                                            scalar_background(0), order16);
  const auto g = bench::exact::gauss_legendre(40);
  const double two_a = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
  for (int py = 0; py < size; ++py)
    for (int px = 0; px < size; ++px) {
      CHECK(at(r8.image, py, px) == Approx(at(r16.image, py, px)).margin(1e-14));
      if (px + py > 5) continue;  // pixels wholly inside the triangle only
      double integral = 0;
      for (int i = 0; i < 40; ++i)
        for (int j = 0; j < 40; ++j) {
          const double x = px + g.nodes[i], y = py + g.nodes[j];
          const double u = ((x - p[0].x) * (p[2].y - p[0].y) - (y - p[0].y) * (p[2].x - p[0].x)) / two_a;
          const double v = ((p[1].x - p[0].x) * (y - p[0].y) - (p[1].y - p[0].y) * (x - p[0].x)) / two_a;
          const double b[3] = {1 - u - v, u, v};
          double num = 0, den = 0;
          for (int k = 0; k < 3; ++k) num += attr[k] * b[k] / p[k].w, den += b[k] / p[k].w;
          integral += g.weights[i] * g.weights[j] * num / den;
        }
      INFO("pixel " << px << ", " << py);
      CHECK(at(r8.coverage, py, px) == Approx(1.0).margin(1e-14));
      CHECK(at(r8.image, py, px) == Approx(integral).margin(1e-13));
    }
}

// A jittered n x n grid of quads over [x0, x1] x [y0, y1] with random w and depths.
void add_jittered_grid(std::vector<ScreenVertex>& v, std::vector<std::int32_t>& t, double x0, double y0, double x1,
                       double y1, double z, int n, std::uint64_t seed) {
  const Tensor noise = Tensor::uniform({(n + 1) * (n + 1), 4}, -1, 1, seed, DType::Float64);
  const double* r = noise.data<double>();
  const auto base = static_cast<std::int32_t>(v.size());
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double* q = r + 4 * (j * (n + 1) + i);
      const bool inner_x = i > 0 && i < n, inner_y = j > 0 && j < n;
      v.push_back({x0 + (x1 - x0) * (i + (inner_x ? 0.3 * q[0] : 0)) / n,
                   y0 + (y1 - y0) * (j + (inner_y ? 0.3 * q[1] : 0)) / n, z + 0.05 * q[2], 1.5 + q[3]});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::int32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      for (std::int32_t k : {a, b, d, a, d, c}) t.push_back(k);
    }
}

TEST_CASE("exact reference: a jittered mesh covers exactly its area, also over another mesh, for any thread count",
          "[exact_reference]") {
  const int size = 8;
  std::vector<ScreenVertex> v;
  std::vector<std::int32_t> t;
  add_jittered_grid(v, t, 1.3, 0.6, 6.7, 7.2, 0.0, 5, 11);
  const Tensor front_clip = clip_of(v, size, size);
  const Tensor front_tris = tris(t);
  const ExactImage front = exact_box_filtered(front_clip, front_tris, column(std::vector<double>(v.size(), 1.0)), size,
                                              size, scalar_background(0));
  double covered = 0, largest = 0;
  for (double c : front.coverage.to_vector()) covered += c, largest = std::max(largest, c);
  CHECK(covered == Approx(5.4 * 6.6).margin(1e-12));
  CHECK(largest <= 1 + 1e-13);

  // Behind it a second jittered mesh over the whole screen: the front mesh's
  // colour (1) covers exactly its area, the back's (0) the rest.
  add_jittered_grid(v, t, -0.5, -0.5, 8.5, 8.5, 0.5, 6, 12);
  std::vector<double> colour(v.size(), 0.0);
  std::fill(colour.begin(), colour.begin() + 36, 1.0);
  const Tensor clip = clip_of(v, size, size);
  set_num_threads(1);
  const ExactImage one = exact_box_filtered(clip, tris(t), column(colour), size, size, scalar_background(0.5));
  set_num_threads(3);
  const ExactImage three = exact_box_filtered(clip, tris(t), column(colour), size, size, scalar_background(0.5));
  set_num_threads(0);
  double front_area = 0, total = 0;
  for (double c : one.image.to_vector()) front_area += c;
  for (double c : one.coverage.to_vector()) total += c;
  CHECK(front_area == Approx(5.4 * 6.6).margin(1e-12));
  CHECK(total == Approx(64.0).margin(1e-12));
  CHECK(one.image.to_vector() == three.image.to_vector());
  CHECK(one.coverage.to_vector() == three.coverage.to_vector());
}

TEST_CASE("exact reference: with only_pixels it computes the flagged pixels alone, the others hold the background",
          "[exact_reference]") {
  const int size = 8;
  std::vector<ScreenVertex> v;
  std::vector<std::int32_t> t;
  add_jittered_grid(v, t, 1.3, 0.6, 6.7, 7.2, 0.0, 5, 11);
  std::vector<double> colour;
  for (std::size_t i = 0; i < v.size(); ++i) colour.push_back(0.1 + 0.02 * double(i % 7));
  const Tensor clip = clip_of(v, size, size), triangles = tris(t), attributes = column(colour);
  const ExactImage all = exact_box_filtered(clip, triangles, attributes, size, size, scalar_background(0.25));
  bench::ExactReferenceOptions options;
  options.only_pixels.assign(size * size, 0);
  for (int i = 0; i < size * size; i += 3) options.only_pixels[i] = 1;
  const ExactImage some = exact_box_filtered(clip, triangles, attributes, size, size, scalar_background(0.25), options);
  int flagged_covered = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      if (options.only_pixels[y * size + x]) {
        CHECK(at(some.image, y, x) == at(all.image, y, x));
        CHECK(at(some.coverage, y, x) == at(all.coverage, y, x));
        flagged_covered += at(all.coverage, y, x) > 0;
      } else {
        CHECK(at(some.image, y, x) == 0.25);
        CHECK(at(some.coverage, y, x) == 0);
      }
    }
  CHECK(flagged_covered > 10);  // the flags do pick covered pixels
  options.only_pixels.pop_back();
  CHECK_THROWS_WITH(exact_box_filtered(clip, triangles, attributes, size, size, scalar_background(0.25), options),
                    Catch::Contains("only_pixels has 63 flags, the image 8x8"));
}

// sum (image - 0.3)^2 over a triangle whose vertex 0 moves by t along x.
template <class Render>
double moved_loss(double t, const Render& render) {
  const std::vector<double> image = render(t);
  double loss = 0;
  for (double x : image) loss += (x - 0.3) * (x - 0.3);
  return loss;
}

TEST_CASE("exact reference: its finite differences are smooth where the point-sampled render's are not",
          "[exact_reference]") {
  // A near-vertical edge at x ~ 3.5004 crosses pixel centres (3.5, y) while
  // vertex 0 moves by less than h: the point-sampled loss jumps there, the
  // box-filtered one does not. Central differences with steps h and 2h agree
  // to O(h^2) for a smooth loss (here f''' h^2 / 2 ~ 1e-5 relative).
  const int size = 8;
  const auto clip_at = [&](double t) {
    return clip_of({{3.5004 + t, 0.2, 0.1, 1}, {3.5004, 7.8, 0.2, 1}, {7.3, 4.1, 0.3, 1}}, size, size);
  };
  const Tensor colours = column({0.9, 0.6, 0.1});
  const auto exact = [&](double t) {
    return exact_box_filtered(clip_at(t), tris({0, 1, 2}), colours, size, size, scalar_background(0.0)).image.to_vector();
  };
  const auto sampled = [&](double t) {
    NoGradGuard no_grad;
    const Tensor clip = clip_at(t);
    return interpolate(colours, rasterize(clip, tris({0, 1, 2}), {size, size}), tris({0, 1, 2})).to_vector();
  };
  const double h = 1e-3;
  const auto differences = [&](const auto& render) {
    const double d1 = (moved_loss(h, render) - moved_loss(-h, render)) / (2 * h);
    const double d2 = (moved_loss(2 * h, render) - moved_loss(-2 * h, render)) / (4 * h);
    return std::array<double, 2>{d1, d2};
  };
  const auto [exact_h, exact_2h] = differences(exact);
  const auto [sampled_h, sampled_2h] = differences(sampled);
  INFO("exact " << exact_h << " " << exact_2h << ", point-sampled " << sampled_h << " " << sampled_2h);
  CHECK(std::abs(exact_h - exact_2h) <= 1e-4 * std::abs(exact_h));  // measured 1.0e-5
  CHECK(std::abs(sampled_h - sampled_2h) > 0.1 * std::abs(sampled_h));
}

TEST_CASE("exact reference: culling follows the rasterizer's winding (counter-clockwise in NDC is front)",
          "[exact_reference]") {
  // NDC (0,0), (1,0), (0,1) is counter-clockwise: front facing.
  const Tensor ccw = Tensor::from_values({0, 0, 0, 1, 1, 0, 0, 1, 0, 1, 0, 1}, {3, 4}, DType::Float64);
  const Tensor attributes = column({1, 1, 1});
  bench::ExactReferenceOptions back, front;
  back.cull = raster::Cull::Back;
  front.cull = raster::Cull::Front;
  const auto covered = [&](const Tensor& t, const bench::ExactReferenceOptions& o) {
    double sum = 0;
    for (double c : exact_box_filtered(ccw, t, attributes, 4, 4, scalar_background(0), o).coverage.to_vector()) sum += c;
    return sum;
  };
  CHECK(covered(tris({0, 1, 2}), back) == Approx(2.0).margin(1e-14));  // half of the 2 x 2 upper-right quarter
  CHECK(covered(tris({0, 1, 2}), front) == 0.0);
  CHECK(covered(tris({0, 2, 1}), back) == 0.0);
  CHECK(covered(tris({0, 2, 1}), front) == Approx(2.0).margin(1e-14));
}

// RMS difference between the reference and the library's render at s x s
// samples per pixel (rasterize + interpolate over the background, box downsample).
double rms_against_supersampled(const Tensor& clip, const Tensor& triangles, const Tensor& attributes,
                                const Tensor& background, int size, int s, const ExactImage& exact) {
  NoGradGuard no_grad;
  InterpolateOptions options;
  options.background = background;
  const Tensor image = downsample_box(
      interpolate(attributes, rasterize(clip, triangles, {s * size, s * size}), triangles, options), s);
  const std::vector<double> a = image.to_vector(), b = exact.image.to_vector();
  double sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(sum / a.size());
}

TEST_CASE("exact reference: agrees with the supersampled render, closer at 16x16 than at 4x4 samples",
          "[exact_reference]") {
  // Two interpenetrating perspective triangles and one crossing the near
  // plane (w < 0 at one vertex), with colours, on a 16 x 16 image.
  const int size = 16;
  const Tensor clip = Tensor::from_values({-0.9, -0.8, 0.2, 1.0, 0.8, -0.6, 0.6, 1.5, -0.1, 0.9, 0.1, 2.0,     //
                                           -0.7, 0.5, 0.5, 1.2, 0.9, 0.7, -0.2, 1.0, 0.2, -1.2, 0.4, 3.0,      //
                                           -0.5, -0.9, 0.5, 1.0, 0.2, -0.2, -1.5, -0.5, 0.9, -0.8, 0.3, 1.0},  //
                                          {9, 4}, DType::Float64);
  const Tensor triangles = tris({0, 1, 2, 3, 4, 5, 6, 7, 8});
  const Tensor attributes = Tensor::uniform({9, 3}, 0, 1, 5, DType::Float64);
  const Tensor background = Tensor::from_values({0.1, 0.2, 0.3}, {3}, DType::Float64);
  const ExactImage exact = exact_box_filtered(clip, triangles, attributes, size, size, background);
  const double rms4 = rms_against_supersampled(clip, triangles, attributes, background, size, 4, exact);
  const double rms16 = rms_against_supersampled(clip, triangles, attributes, background, size, 16, exact);
  INFO("RMS difference: 4x4 samples " << rms4 << ", 16x16 samples " << rms16);
  CHECK(rms16 < 0.5 * rms4);
  CHECK(rms16 < 2e-3);
}

TEST_CASE("exact reference: degenerate and grazing configurations give finite images and coverage at most 1",
          "[exact_reference]") {
  const int size = 8;
  std::vector<ScreenVertex> v;
  std::vector<std::int32_t> t;
  // 0-1: a full-screen quad; 2-3: the same quad with its corners in another
  // order (so its depth plane is rounded differently): coplanar, index 0-1 wins.
  add_quad(v, t, -1, -1, 9, 9, 0.3, 1.7);
  v.push_back(v[2]), v.push_back(v[3]), v.push_back(v[0]), v.push_back(v[1]);
  for (int k : {0, 1, 2, 0, 2, 3}) t.push_back(4 + k);
  // 4-5: a plane crossing the first one at a grazing angle along x = 4.2
  // (depth slope 1e-9 per pixel).
  for (const auto& p : {std::array<double, 2>{-1, -1}, {9, -1}, {9, 9}, {-1, 9}})
    v.push_back({p[0], p[1], 0.3 + 1e-9 * (p[0] - 4.2), 1.0});
  for (int k : {0, 1, 2, 0, 2, 3}) t.push_back(8 + k);
  // A zero-area triangle and a sliver, both in front.
  v.push_back({1, 1, 0.1, 1}), v.push_back({2, 2, 0.1, 1}), v.push_back({3, 3, 0.1, 1});
  v.push_back({1, 5, 0.1, 1}), v.push_back({7, 5 + 1e-12, 0.1, 1}), v.push_back({4, 5, 0.1, 1});
  for (int k = 12; k < 18; ++k) t.push_back(k);
  std::vector<double> colour(v.size(), 0.0);
  for (int k = 0; k < 4; ++k) colour[k] = 1;     // the winning coplanar quad
  for (int k = 4; k < 8; ++k) colour[k] = 5;     // its hidden twin
  for (int k = 8; k < 12; ++k) colour[k] = -1;   // the grazing plane
  Tensor clip = clip_of(v, size, size);
  // One more triangle through w = 0 exactly at a vertex, and one wholly behind the eye.
  std::vector<double> extra = clip.to_vector();
  for (double x : {0.2, 0.1, 0.5, 0.0, -0.5, 0.5, 0.5, 1.0, 0.5, -0.5, 0.5, 1.0,  //
                   0.1, 0.1, 0.1, -1.0, 0.3, 0.1, 0.1, -2.0, 0.1, 0.4, 0.1, -1.0})
    extra.push_back(x);
  const auto n = static_cast<std::int32_t>(v.size());
  for (std::int32_t k = 0; k < 6; ++k) t.push_back(n + k), colour.push_back(2.0);
  clip = Tensor::from_values(extra, {n + 6, 4}, DType::Float64);
  const ExactImage r = exact_box_filtered(clip, tris(t), column(colour), size, size, scalar_background(0));
  for (double c : r.coverage.to_vector()) {
    CHECK(std::isfinite(c));
    CHECK(c <= 1 + 1e-12);
  }
  for (double x : r.image.to_vector()) CHECK(std::isfinite(x));
  // The grazing plane is in front left of x = 4.2; right of it the coplanar
  // winner shows (colour 1, never its twin's 5); pixel column 4 holds both.
  CHECK(at(r.image, 1, 0) == Approx(-1.0).margin(1e-12));
  CHECK(at(r.image, 7, 7) == Approx(1.0).margin(1e-12));
  CHECK(at(r.image, 2, 4) == Approx(0.2 * -1.0 + 0.8 * 1.0).margin(1e-6));
}

TEST_CASE("exact reference: bad inputs are refused naming the input", "[exact_reference]") {
  const Tensor clip = Tensor::from_values({0, 0, 0, 1, 1, 0, 0, 1, 0, 1, 0, 1}, {3, 4}, DType::Float64);
  const Tensor triangles = tris({0, 1, 2});
  const Tensor attributes = column({1, 1, 1});
  const Tensor bg = scalar_background(0);
  CHECK_THROWS_AS(exact_box_filtered(Tensor::zeros({3, 3}, DType::Float64), triangles, attributes, 4, 4, bg), ShapeError);
  CHECK_THROWS_AS(exact_box_filtered(Tensor::zeros({3, 4}, DType::Float32), triangles, attributes, 4, 4, bg), DTypeError);
  CHECK_THROWS_AS(exact_box_filtered(clip, tris({0, 1, 3}), attributes, 4, 4, bg), IndexError);
  CHECK_THROWS_AS(exact_box_filtered(clip, triangles, column({1, std::nan(""), 1}), 4, 4, bg), ValueError);
  CHECK_THROWS_AS(exact_box_filtered(clip, triangles, attributes, 4, 4, Tensor::zeros({2}, DType::Float64)), ShapeError);
  CHECK_THROWS_AS(exact_box_filtered(clip, triangles, attributes, 0, 4, bg), ValueError);
  const Tensor huge = Tensor::from_values({0, 0, 0, 1, 1e300, 0, 0, 1, 0, 1e300, 0, 1}, {3, 4}, DType::Float64);
  CHECK_THROWS_WITH(exact_box_filtered(huge, triangles, attributes, 4, 4, bg), Catch::Contains("triangle 0"));
}

}  // namespace
}  // namespace gr
