// Numerical-stability stress scenes (issue 7), shared by the [stress] tests
// (tests/stress/test_stress.cpp) and the report program (bench/stress_report.cpp).
//
// Each Case is a small scene run through the whole pipeline
//   model positions --transform_points--> clip --rasterize--> G-buffer
//   --interpolate--> shading --antialias (where relevant)--> image
// with a dtype-generic render function: it computes in the dtype of its inputs,
// so the same scene runs in float64 (reference, gradcheck) and float32.
// evaluate() renders, takes L = sum(image * R) for fixed random weights R and
// runs backward; compare() gives the float32-vs-float64 relative errors; and
// run_gradcheck() checks the float64 gradients of the inputs the case marks as
// smooth against finite differences, counting any perturbation that changed
// the coverage (tri_id), which would make the check meaningless.
//
// No Catch2 in here: the report program includes it too.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "ops/ops.h"
#include "raster/procedural.h"

namespace gr::stress {

// What a render function returns: the shaded image and the coverage it used.
struct Render {
  Tensor image;   // [H, W, C] in the inputs' dtype
  Tensor tri_id;  // [H, W] int32
};
using RenderFn = std::function<Render(const std::vector<Tensor>&)>;

struct Case {
  std::string group;  // "near plane", "scale", "shape", "shading"
  std::string name;
  std::vector<Tensor> inputs;  // float64 values (no requires_grad); all receive gradients
  std::vector<std::string> input_names;
  RenderFn render;
  // Finite-difference checks, each over some inputs with its own step (a
  // step that keeps a tiny sliver's coverage is far too small for colours).
  // Inputs in no check are not smooth at the scene's point: see `note`.
  struct Check {
    std::vector<int> inputs;
    GradcheckOptions gc;
  };
  std::vector<Check> checks;
  std::string note;  // why an input is not checked, if one is not
  // Convenience: one check per input group, default tolerances rtol 1e-4.
  void check(std::vector<int> inputs, double eps, double rtol = 1e-4, double atol = 1e-7) {
    GradcheckOptions o;
    o.eps = eps;
    o.rtol = rtol;
    o.atol = atol;
    checks.push_back({std::move(inputs), o});
  }
};

// ---------------------------------------------------------------- helpers

inline Tensor f64(const std::vector<double>& v, const Shape& s) { return Tensor::from_values(v, s, DType::Float64); }

inline Tensor tri_tensor(const std::vector<std::int32_t>& t) {
  return Tensor::from_vector(t, {static_cast<std::int64_t>(t.size() / 3), 3});
}

// Model position (view space of a camera at the origin looking down -z with
// perspective(fov, W/H)) that lands on screen point (sx, sy) at depth w > 0.
inline void place(std::vector<double>& pos, double sx, double sy, double w, int W, int H, double fov) {
  const double f = 1.0 / std::tan(0.5 * fov), aspect = double(W) / H;
  const double xn = 2.0 * sx / W - 1.0, yn = 1.0 - 2.0 * sy / H;
  pos.push_back(xn * w * aspect / f);
  pos.push_back(yn * w / f);
  pos.push_back(-w);
}

// Fixed colours in [0.2, 0.9] for n vertices.
inline Tensor colours_for(std::int64_t n, std::uint64_t seed) {
  return Tensor::uniform({n, 3}, 0.2, 0.9, seed, DType::Float64);
}

// Standard render: inputs {positions [N,3], colours [N,C]}; the MVP comes from
// `mvp(dtype)`; image = interpolate(colours) + 0.05 depth, then antialias if asked.
inline RenderFn standard_render(Tensor triangles, int W, int H, std::function<Tensor(DType)> mvp, bool aa) {
  return [=](const std::vector<Tensor>& in) {
    const Tensor clip = transform_points(in[0], mvp(in[0].dtype()));
    const GBuffer gb = rasterize(clip, triangles, {W, H});
    Tensor img = interpolate(in[1], gb, triangles) + 0.05 * reshape(gb.depth, {H, W, 1});
    if (aa) img = antialias(img, gb, clip, triangles);
    return Render{img, gb.tri_id};
  };
}

inline std::function<Tensor(DType)> camera_at_origin(double fov, double aspect, double near, double far) {
  return [=](DType dt) { return perspective(fov, aspect, near, far, ClipSpace::OpenGL, dt); };
}

inline std::string sci(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0e", x);
  return buf;
}

// ---------------------------------------------------------------- near plane

// Smallest finite-difference step for the near-plane vertex (taken for |w| < 1e-2).
constexpr double kClippedVertexStep = 1e-7;

// A background quad at w = 3 and a triangle whose third vertex sits at view
// depth w (fixed view x, y), so its screen position runs off to ~0.04/w
// pixels as w -> 0 and it crosses the eye plane for w <= 0. near = 5e-4: for
// w < 5e-4 the triangle is near-clipped (homogeneous path), and interpolate
// takes its perspective weights F_k / D from the clip positions, smooth
// through w = 0.
// inputs {positions [6,3], colours [7,3], vertex [1,3]} (the special vertex
// separately, with its own finite-difference step).
inline Case near_plane_case(double w) {
  const int W = 32, H = 32;
  const double fov = 1.0;
  std::vector<double> p;
  place(p, 1.3, 1.2, 3.0, W, H, fov);
  place(p, 30.7, 2.1, 3.0, W, H, fov);
  place(p, 30.1, 30.8, 3.0, W, H, fov);
  place(p, 2.1, 30.2, 3.0, W, H, fov);
  place(p, 4.3, 26.1, 1.0, W, H, fov);
  place(p, 27.2, 24.7, 1.3, W, H, fov);
  Case c;
  c.group = "near plane";
  c.name = "vertex w = " + (w == 0 ? std::string("0") : sci(w));
  c.inputs = {f64(p, {6, 3}), colours_for(7, 11), f64({0.013, 0.021, -w}, {1, 3})};
  c.input_names = {"positions", "colours", "vertex"};
  const Tensor triangles = tri_tensor({0, 2, 1, 0, 3, 2, 4, 5, 6});
  const RenderFn inner = standard_render(triangles, W, H, camera_at_origin(fov, 1.0, 5e-4, 100.0), true);
  c.render = [inner](const std::vector<Tensor>& in) { return inner({concat({in[0], in[2]}, 0), in[1]}); };
  c.check({0}, 1e-6);
  c.check({1}, 1e-3);
  // The vertex: steps of 1e-5 |w|, but at least kClippedVertexStep. For
  // |w| < near the triangle is clipped and the image is smooth through w = 0
  // (interpolate's F_k / D), so the steps may cross it; they keep the coverage
  // (checked). atol covers the finite-difference rounding noise,
  // ~1e-16 |L| / eps with |L| ~ 1e3.
  const double eps = std::max(1e-5 * std::fabs(w), kClippedVertexStep);
  c.check({2}, eps, 1e-4, 1e-7 + 2e-13 / eps);
  return c;
}

// near / far = 1e-4 / 1e5: two quads 1000 units away, 1e-3 apart in depth
// (z_ndc differ by ~2e-13), the farther one drawn first.
inline Case depth_precision_case() {
  const int W = 24, H = 24;
  const double fov = 0.8;
  std::vector<double> p;
  auto quad = [&](double x0, double y0, double x1, double y1, double w) {
    place(p, x0, y0, w, W, H, fov);
    place(p, x1, y0, w, W, H, fov);
    place(p, x1, y1, w, W, H, fov);
    place(p, x0, y1, w, W, H, fov);
  };
  quad(1.3, 1.7, 22.6, 22.2, 1000.001);  // back
  quad(6.2, 5.8, 18.4, 19.1, 1000.0);    // front
  Case c;
  c.group = "near plane";
  c.name = "near/far 1e-4/1e5, gap 1e-3 at 1000";
  c.inputs = {f64(p, {8, 3}), colours_for(8, 12)};
  c.input_names = {"positions", "colours"};
  c.render = standard_render(tri_tensor({0, 2, 1, 0, 3, 2, 4, 6, 5, 4, 7, 6}), W, H,
                             camera_at_origin(fov, 1.0, 1e-4, 1e5), true);
  c.check({0, 1}, 1e-5);  // keeps the 1e-3 depth gap and every edge's pixel coverage
  return c;
}

// ---------------------------------------------------------------- scale

// An icosphere of radius 0.8 s seen from (0.3, 0.4, 2.6) s with near/far 0.5 s
// / 10 s: the same image for every s, gradients w.r.t. positions scaled by 1/s.
inline Case scale_case(double s) {
  const int W = 28, H = 24;
  raster::Mesh mesh = raster::make_icosphere(1, 0.8f);
  std::vector<double> pos = mesh.positions.to_vector();
  for (double& x : pos) x *= s;
  Case c;
  c.group = "scale";
  c.name = "icosphere at " + sci(s) + " world units";
  c.inputs = {f64(pos, {mesh.num_vertices(), 3}), colours_for(mesh.num_vertices(), 13)};
  c.input_names = {"positions", "colours"};
  auto mvp = [s, W, H](DType dt) {
    Tensor eye = Tensor::from_values({0.3 * s, 0.4 * s, 2.6 * s}, {3}, dt);
    Tensor target = Tensor::zeros({3}, dt);
    Tensor up = Tensor::from_values({0, 1, 0}, {3}, dt);
    return matmul(perspective(0.9, double(W) / H, 0.5 * s, 10.0 * s, ClipSpace::OpenGL, dt),
                  look_at(eye, target, up));
  };
  c.render = standard_render(mesh.triangles, W, H, mvp, true);
  c.check({0}, 1e-5 * s, 1e-4, 1e-7 / s);
  c.check({1}, 1e-3);
  return c;
}

// One triangle covering the whole 32x32 screen with its vertices about 1e6
// pixels outside the viewport, at different depths, plus a normal-sized
// triangle in front of it (so silhouettes exist).
inline Case far_outside_case() {
  const int W = 32, H = 32;
  const double fov = 1.0;
  std::vector<double> p;
  place(p, -1e6, -1e6, 2.0, W, H, fov);
  place(p, 1e6 + 16, -1e6 + 3, 2.5, W, H, fov);
  place(p, 16.3, 1e6, 3.0, W, H, fov);
  place(p, 8.2, 7.7, 1.0, W, H, fov);
  place(p, 24.6, 11.3, 1.2, W, H, fov);
  place(p, 13.1, 26.4, 1.1, W, H, fov);
  Case c;
  c.group = "scale";
  c.name = "vertices 1e6 px off screen";
  c.inputs = {f64(p, {6, 3}), colours_for(6, 14)};
  c.input_names = {"positions", "colours"};
  c.render = standard_render(tri_tensor({0, 2, 1, 3, 5, 4}), W, H, camera_at_origin(fov, 1.0, 0.1, 100.0), true);
  c.check({0, 1}, 1e-5);
  return c;
}

// ---------------------------------------------------------------- shape

// A sliver along the row of pixel centres y = 16.5 with 2A = area2 (pixels^2):
// base 27.4 px, height 2 d; pixel centres 9.5 .. 22.5 of that row are inside.
// Drawn over a background quad, antialiased.
inline Case sliver_case(double area2) {
  const int W = 32, H = 32;
  const double fov = 1.0;
  const double d = area2 / (2 * 27.4);
  std::vector<double> p;
  place(p, 1.3, 1.2, 3.0, W, H, fov);
  place(p, 30.7, 2.1, 3.0, W, H, fov);
  place(p, 30.1, 30.8, 3.0, W, H, fov);
  place(p, 2.1, 30.2, 3.0, W, H, fov);
  place(p, 2.3, 16.5 - d, 1.0, W, H, fov);
  place(p, 29.7, 16.5 - d, 1.0, W, H, fov);
  place(p, 16.0, 16.5 + d, 1.0, W, H, fov);
  Case c;
  c.group = "shape";
  c.name = "sliver 2A = " + sci(area2);
  c.inputs = {f64(p, {7, 3}), colours_for(7, 15)};
  c.input_names = {"positions", "colours"};
  c.render = standard_render(tri_tensor({0, 2, 1, 0, 3, 2, 4, 5, 6}), W, H,
                             camera_at_origin(fov, 1.0, 0.1, 100.0), true);
  if (area2 >= 1e-4) {
    // A vertex moves ~30 px per unit: steps of 1e-2 d / 30 keep the coverage.
    const double eps = 1e-2 * d / 30.0;
    c.check({0}, eps, 1e-4, 1e-7 + 2e-13 / eps);
    c.check({1}, 1e-3);
  } else {
    c.check({1}, 1e-3);
    c.note = "positions: a step small enough to keep the coverage is below float64 resolution";
  }
  return c;
}

// 24 triangles of ~0.4 px, half around a pixel centre, half between centres
// (covering none), over a background quad, antialiased.
inline Case subpixel_case() {
  const int W = 32, H = 32;
  const double fov = 1.0;
  std::vector<double> p;
  place(p, 1.3, 1.2, 3.0, W, H, fov);
  place(p, 30.7, 2.1, 3.0, W, H, fov);
  place(p, 30.1, 30.8, 3.0, W, H, fov);
  place(p, 2.1, 30.2, 3.0, W, H, fov);
  std::vector<std::int32_t> t = {0, 2, 1, 0, 3, 2};
  for (int k = 0; k < 24; ++k) {
    const double cx = 4.5 + 4 * (k % 6) + (k % 2 ? 0.5 : 0.0);  // odd k: between centres
    const double cy = 4.5 + 4 * (k / 6) + (k % 2 ? 0.5 : 0.0);
    const std::int32_t b = static_cast<std::int32_t>(p.size() / 3);
    place(p, cx - 0.21, cy + 0.17, 1.0 + 0.01 * k, W, H, fov);
    place(p, cx + 0.19, cy + 0.13, 1.0 + 0.01 * k, W, H, fov);
    place(p, cx + 0.02, cy - 0.23, 1.0 + 0.01 * k, W, H, fov);
    t.insert(t.end(), {b, b + 1, b + 2});
  }
  const std::int64_t n = static_cast<std::int64_t>(p.size() / 3);
  Case c;
  c.group = "shape";
  c.name = "sub-pixel triangles (0.4 px)";
  c.inputs = {f64(p, {n, 3}), colours_for(n, 16)};
  c.input_names = {"positions", "colours"};
  c.render = standard_render(tri_tensor(t), W, H, camera_at_origin(fov, 1.0, 0.1, 100.0), true);
  c.check({0}, 1e-6);
  c.check({1}, 1e-3);
  return c;
}

// A 6x6-cell grid (72 triangles, diagonals alternating) whose vertices lie
// exactly on pixel centres (4 px cells from 4.5 to 28.5), so every vertex is
// on a centre and every edge, diagonals included, runs through centres.
// Orthographic-like clip (identity MVP, w = 1): exact in float32 and float64.
inline Case pixel_centre_grid_case() {
  const int W = 32, H = 32, n = 6;
  std::vector<double> p;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double sx = 4.5 + 4 * i, sy = 4.5 + 4 * j;
      p.insert(p.end(), {2 * sx / W - 1, 1 - 2 * sy / H, 0.25 * ((i + j) % 3) - 0.25});
    }
  std::vector<std::int32_t> t;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::int32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      if ((i + j) % 2) t.insert(t.end(), {a, c, b, b, c, d});
      else t.insert(t.end(), {a, d, b, a, c, d});
    }
  Case c;
  c.group = "shape";
  c.name = "vertices & edges on pixel centres";
  c.inputs = {f64(p, {(n + 1) * (n + 1), 3}), colours_for((n + 1) * (n + 1), 17)};
  c.input_names = {"positions", "colours"};
  c.render = standard_render(tri_tensor(t), W, H, [](DType dt) { return identity4(dt); }, false);
  c.check({1}, 1e-3);
  c.note = "positions: every pixel centre is on an edge, so any step changes coverage (not smooth)";
  return c;
}

// z-fighting: two exactly coplanar, overlapping triangles (plane at w = 2,
// different vertices) and an exact duplicate of a third triangle with
// another colour. Ties go to the smaller triangle id.
inline Case zfight_case() {
  const int W = 32, H = 32;
  const double fov = 1.0;
  std::vector<double> p;
  place(p, 2.6, 3.1, 2.0, W, H, fov);
  place(p, 29.2, 6.3, 2.0, W, H, fov);
  place(p, 9.7, 29.4, 2.0, W, H, fov);
  place(p, 4.1, 14.8, 2.0, W, H, fov);
  place(p, 27.3, 2.2, 2.0, W, H, fov);
  place(p, 25.6, 28.7, 2.0, W, H, fov);
  // Duplicate pair (identical coordinates, distinct vertices for distinct colours).
  for (int k = 0; k < 2; ++k) {
    place(p, 12.2, 10.4, 1.5, W, H, fov);
    place(p, 21.7, 12.9, 1.6, W, H, fov);
    place(p, 15.1, 22.3, 1.7, W, H, fov);
  }
  Case c;
  c.group = "shape";
  c.name = "coplanar overlap + duplicate (z-fight)";
  c.inputs = {f64(p, {12, 3}), colours_for(12, 18)};
  c.input_names = {"positions", "colours"};
  c.render = standard_render(tri_tensor({0, 2, 1, 3, 5, 4, 9, 11, 10, 6, 8, 7}), W, H,
                             camera_at_origin(fov, 1.0, 0.1, 100.0), false);
  c.check({1}, 1e-3);
  c.note = "positions: moving a vertex breaks an exact depth tie (not smooth)";
  return c;
}

// ---------------------------------------------------------------- shading

// Two triangles forming a quad with unshared vertices: triangle 1 has all-zero
// shading attributes S (so the singular point is hit on every one of its
// pixels), triangle 2 positive ones. inputs {positions, colours, S}; the
// shading function maps (colour image, S image) to the final image.
inline Case shading_case(const std::string& name, int s_channels, const std::vector<double>& s_tri2,
                         std::function<Tensor(const Tensor&, const Tensor&)> shade) {
  const int W = 16, H = 16;
  const double fov = 1.0;
  std::vector<double> p;
  place(p, 1.3, 1.2, 2.0, W, H, fov);
  place(p, 14.7, 1.3, 2.1, W, H, fov);
  place(p, 1.2, 14.7, 2.2, W, H, fov);
  place(p, 14.7, 1.3, 2.1, W, H, fov);
  place(p, 14.8, 14.6, 2.3, W, H, fov);
  place(p, 1.2, 14.7, 2.2, W, H, fov);
  std::vector<double> s(3 * s_channels, 0.0);
  s.insert(s.end(), s_tri2.begin(), s_tri2.end());
  const Tensor triangles = tri_tensor({0, 2, 1, 3, 5, 4});
  Case c;
  c.group = "shading";
  c.name = name;
  c.inputs = {f64(p, {6, 3}), colours_for(6, 19), f64(s, {6, s_channels})};
  c.input_names = {"positions", "colours", "S"};
  c.render = [=](const std::vector<Tensor>& in) {
    const Tensor clip = transform_points(in[0], perspective(fov, 1.0, 0.1, 100.0, ClipSpace::OpenGL, in[0].dtype()));
    const GBuffer gb = rasterize(clip, triangles, {W, H});
    const Tensor col = interpolate(in[1], gb, triangles);
    const Tensor sv = interpolate(in[2], gb, triangles);
    return Render{shade(col, sv), gb.tri_id};
  };
  c.check({0}, 1e-6);
  c.check({1}, 1e-3);
  c.note = "S: checked only by the documented finite convention (the true derivative diverges at 0)";
  return c;
}

inline Case normalize_zero_case() {
  return shading_case("normalize(0) in Lambert", 3, {0.2, 0.3, 1.0, -0.1, 0.4, 0.9, 0.1, -0.2, 1.1},
                      [](const Tensor& col, const Tensor& n) {
                        const Tensor l = normalize(Tensor::from_values({0.3, 0.5, 1.0}, {3}, col.dtype()));
                        return col * (0.5 + 0.5 * dot(normalize(n), l));
                      });
}

inline Case pow_zero_case(double p) {
  return shading_case("pow(0, " + std::to_string(p).substr(0, 4) + ")", 1, {0.3, 0.8, 0.55},
                      [p](const Tensor& col, const Tensor& s) { return col * pow(s, p); });
}

inline Case sqrt_zero_case() {
  return shading_case("sqrt(0)", 1, {0.3, 0.8, 0.55},
                      [](const Tensor& col, const Tensor& s) { return col * sqrt(s) + length(s * col); });
}

// image = colour * 1e-3 / D with D interpolated from per-vertex values in
// [1, 2] delta on BOTH triangles (delta down to 1e-12): large but finite values
// and gradients (|dL/dD| ~ 1e-3 / delta^2); gradcheck w.r.t. D with steps 1e-3 delta.
inline Case division_case(double delta) {
  const int W = 16, H = 16;
  const double fov = 1.0;
  std::vector<double> p;
  place(p, 1.3, 1.2, 2.0, W, H, fov);
  place(p, 14.7, 1.3, 2.1, W, H, fov);
  place(p, 1.2, 14.7, 2.2, W, H, fov);
  place(p, 14.8, 14.6, 2.3, W, H, fov);
  const Tensor triangles = tri_tensor({0, 2, 1, 1, 2, 3});
  Case c;
  c.group = "shading";
  c.name = "colour * 1e-3 / D, D ~ " + sci(delta);
  c.inputs = {f64(p, {4, 3}), colours_for(4, 20), f64({1.0 * delta, 1.7 * delta, 1.3 * delta, 2.0 * delta}, {4, 1})};
  c.input_names = {"positions", "colours", "D"};
  c.render = [=](const std::vector<Tensor>& in) {
    const Tensor clip = transform_points(in[0], perspective(fov, 1.0, 0.1, 100.0, ClipSpace::OpenGL, in[0].dtype()));
    const GBuffer gb = rasterize(clip, triangles, {W, H});
    InterpolateOptions o;
    o.background = Tensor::ones({1}, in[0].dtype());  // no 0 denominators on background
    const Tensor d = interpolate(in[2], gb, triangles, o);
    const Tensor col = interpolate(in[1], gb, triangles);
    return Render{col * 1e-3 / d, gb.tri_id};
  };
  c.check({0}, 1e-6, 1e-4, 0);
  c.check({1}, 1e-3, 1e-4, 0);
  c.check({2}, 1e-3 * delta, 1e-4, 0);
  return c;
}

// ---------------------------------------------------------------- all cases

inline std::vector<Case> near_plane_cases() {
  std::vector<Case> v;
  for (double w : {1e-1, 1e-3, 1e-5, 1e-7, 1e-15, 0.0, -1e-15, -1e-7, -1e-1}) v.push_back(near_plane_case(w));
  v.push_back(depth_precision_case());
  return v;
}
inline std::vector<Case> scale_cases() { return {scale_case(1e-6), scale_case(1.0), scale_case(1e6), far_outside_case()}; }
inline std::vector<Case> shape_cases() {
  std::vector<Case> v;
  for (double a : {1e-2, 1e-4, 1e-6, 1e-9, 1e-12}) v.push_back(sliver_case(a));
  v.push_back(subpixel_case());
  v.push_back(pixel_centre_grid_case());
  v.push_back(zfight_case());
  return v;
}
inline std::vector<Case> shading_cases() {
  return {normalize_zero_case(), pow_zero_case(0.25), pow_zero_case(0.5), pow_zero_case(0.75),
          sqrt_zero_case(), division_case(1e-4), division_case(1e-8), division_case(1e-12)};
}
inline std::vector<Case> all_cases() {
  std::vector<Case> v;
  for (auto group : {near_plane_cases(), scale_cases(), shape_cases(), shading_cases()})
    v.insert(v.end(), group.begin(), group.end());
  return v;
}

// ---------------------------------------------------------------- evaluation

struct Evaluation {
  Tensor image;                // [H, W, C]
  Tensor tri_id;               // [H, W]
  std::vector<Tensor> grads;   // dL/d input (zeros if none reached it)
  bool image_finite = false;
  bool grads_finite = false;
  bool finite() const { return image_finite && grads_finite; }
};

inline bool finite(const Tensor& t) {
  for (double x : t.to_vector())
    if (!std::isfinite(x)) return false;
  return true;
}

// Renders the case in `dtype`, L = sum(image * R) with fixed R in [0.5, 1.5],
// backward; every input receives a gradient.
inline Evaluation evaluate(const Case& c, DType dtype) {
  std::vector<Tensor> in;
  for (const Tensor& t : c.inputs) {
    Tensor x = cast(t, dtype).copy();
    x.set_requires_grad();
    in.push_back(x);
  }
  Render r = c.render(in);
  Evaluation e;
  e.image = r.image.detach();
  e.tri_id = r.tri_id;
  const Tensor weights = Tensor::uniform(r.image.shape(), 0.5, 1.5, 777, dtype);
  backward(sum(r.image * weights));
  e.image_finite = finite(e.image);
  e.grads_finite = true;
  for (Tensor& x : in) {
    Tensor g = x.grad().defined() ? x.grad() : Tensor::zeros(x.shape(), dtype);
    e.grads_finite = e.grads_finite && finite(g);
    e.grads.push_back(g);
  }
  return e;
}

// max |a - b| / max |b| (b the float64 reference); 0 if both are all zero.
inline double rel_error(const Tensor& a, const Tensor& b) {
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  double num = 0, den = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    num = std::max(num, std::fabs(x[i] - y[i]));
    den = std::max(den, std::fabs(y[i]));
  }
  if (num == 0) return 0;
  return den > 0 ? num / den : std::numeric_limits<double>::infinity();
}

struct Comparison {
  double image_rel = 0;    // float32 image vs float64
  double grad_rel = 0;     // worst over inputs of float32 gradient vs float64
  std::string worst_grad;  // input name of grad_rel
  std::int64_t coverage_diff = 0;  // pixels whose tri_id differs between float32 and float64
};

inline Comparison compare(const Case& c, const Evaluation& e32, const Evaluation& e64) {
  Comparison out;
  out.image_rel = rel_error(e32.image, e64.image);
  for (std::size_t k = 0; k < e64.grads.size(); ++k) {
    const double r = rel_error(e32.grads[k], e64.grads[k]);
    if (r >= out.grad_rel) {
      out.grad_rel = r;
      out.worst_grad = c.input_names[k];
    }
  }
  const std::int32_t* a = e32.tri_id.data<std::int32_t>();
  const std::int32_t* b = e64.tri_id.data<std::int32_t>();
  for (std::int64_t i = 0; i < e64.tri_id.numel(); ++i) out.coverage_diff += a[i] != b[i];
  return out;
}

struct GradcheckRun {
  GradcheckResult result;
  std::int64_t coverage_changes = 0;  // evaluations whose tri_id differed from the unperturbed one
};

// gradcheck in float64 of check.inputs (the others are held constant).
inline GradcheckRun run_gradcheck(const Case& c, const Case::Check& check) {
  std::vector<Tensor> in;
  for (std::size_t k = 0; k < c.inputs.size(); ++k) {
    Tensor x = c.inputs[k].copy();
    if (std::find(check.inputs.begin(), check.inputs.end(), int(k)) != check.inputs.end()) x.set_requires_grad();
    in.push_back(x);
  }
  Tensor reference;
  {
    NoGradGuard guard;
    reference = c.render(in).tri_id;
  }
  auto changes = std::make_shared<std::int64_t>(0);
  const RenderFn render = c.render;
  GradcheckFn f = [render, reference, changes](const std::vector<Tensor>& x) {
    const Render r = render(x);  // const: a non-const data<T>() would count as a write into tri_id
    const std::int32_t* a = r.tri_id.data<std::int32_t>();
    const std::int32_t* b = reference.data<std::int32_t>();
    for (std::int64_t i = 0; i < reference.numel(); ++i)
      if (a[i] != b[i]) {
        ++*changes;
        break;
      }
    return r.image;
  };
  GradcheckRun run;
  run.result = gradcheck(f, in, check.gc);
  run.coverage_changes = *changes;
  return run;
}

}  // namespace gr::stress
