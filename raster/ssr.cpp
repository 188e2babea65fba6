// Screen-space reflection tracers (raster/ssr.h): ray set-up, the shared
// depth-band hit test, the view-space march (tracer A), the McGuire-Mara DDA
// (tracer B), the dense screen-space reference, and the plain fades.
#include "raster/ssr.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"

namespace gr::raster {

namespace {

using Vec3 = std::array<double, 3>;
using Mat4 = std::array<double, 16>;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Clip {
  double x, y, z, w;
};

Clip to_clip(const Mat4& m, const Vec3& p) {
  auto row = [&](int r) { return m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] + m[4 * r + 3]; };
  return {row(0), row(1), row(2), row(3)};
}

bool finite3(const Vec3& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }

// Finite once stored as T (false for NaN, Inf and doubles beyond FLT_MAX for float).
template <class T>
bool fits(double x) {
  return std::abs(x) <= static_cast<double>(std::numeric_limits<T>::max());
}

// Scene depth test at pixel (i, j) for a ray depth interval [zlo, zhi].
bool depth_hit(const SsrDepth& d, int i, int j, double zlo, double zhi) {
  if (i < 0 || j < 0 || i >= d.width || j >= d.height) return false;
  const std::size_t k = static_cast<std::size_t>(j) * d.width + i;
  const double f = d.front[k];
  return f > -kInf && zlo <= f && zhi >= d.lower[k];
}

// Refinement test: the point is behind the front surface of pixel (i, j). The
// binary searches look for the crossing from "in front" to "behind", which is
// monotone along a ray meeting one surface (the band test is not: a thin band
// can fall between two bisection points, and the search then drifts to its end).
bool depth_behind(const SsrDepth& d, int i, int j, double z) {
  if (i < 0 || j < 0 || i >= d.width || j >= d.height) return false;
  const double f = d.front[static_cast<std::size_t>(j) * d.width + i];
  return f > -kInf && z <= f;
}

SsrHit no_hit(std::int64_t samples) {
  SsrHit h;
  h.samples = samples;
  return h;
}

// ---- Tracer A: fixed steps in view space --------------------------------------
SsrHit trace_view_space(const SsrDepth& d, const Mat4& m, const SsrRay& ray, int px, int py,
                        const SsrOptions& o, std::vector<std::array<int, 2>>* visited) {
  const int W = d.width, H = d.height;
  std::int64_t samples = 0;
  auto at = [&](double t) {
    return Vec3{ray.origin[0] + t * ray.length * ray.dir[0], ray.origin[1] + t * ray.length * ray.dir[1],
                ray.origin[2] + t * ray.length * ray.dir[2]};
  };
  // Projects Q; returns false off screen (or behind the camera).
  auto pixel_of = [&](const Vec3& q, double& xs, double& ys, int& i, int& j) {
    if (!ssr_project(m, W, H, q, xs, ys)) return false;
    if (!(xs >= 0 && ys >= 0 && xs < W && ys < H)) return false;
    i = static_cast<int>(xs), j = static_cast<int>(ys);
    return true;
  };
  // Refinement predicate: behind the front surface at the sample's pixel.
  auto behind = [&](double t) {
    const Vec3 q = at(t);
    double xs, ys;
    int i, j;
    ++samples;
    if (!pixel_of(q, xs, ys, i, j) || (i == px && j == py)) return false;
    return depth_behind(d, i, j, q[2]);
  };

  {
    // The origin projects into its pixel; off the screen, no tracer marches (screen_line).
    double xs, ys;
    int i, j;
    if (!pixel_of(ray.origin, xs, ys, i, j)) return no_hit(0);
  }
  const int steps = o.max_steps;
  double prev = 0;
  for (int n = 1; n <= steps; ++n) {
    const double t = static_cast<double>(n) / steps;
    const Vec3 q = at(t);
    double xs, ys;
    int i, j;
    // A straight segment in front of the camera cannot come back on screen once it left.
    if (!pixel_of(q, xs, ys, i, j)) break;
    if (i == px && j == py) {
      prev = t;
      continue;
    }
    if (visited) visited->push_back({i, j});
    ++samples;
    if (depth_hit(d, i, j, q[2], q[2])) {
      // Binary search between the last miss and this hit.
      double lo = prev, hi = t;
      for (int b = 0; b < o.binary_steps; ++b) {
        const double mid = 0.5 * (lo + hi);
        (behind(mid) ? hi : lo) = mid;
      }
      SsrHit h;
      h.hit = true;
      h.point = at(hi);
      ssr_project(m, W, H, h.point, h.x, h.y);
      h.distance = hi * ray.length;
      h.samples = samples;
      return h;
    }
    prev = t;
  }
  return no_hit(samples);
}

// ---- Screen-space line shared by the DDA and the reference -----------------------
// Q/w, 1/w and the screen position are affine in screen space, parametrized by s =
// pixels travelled along the major axis from the projected origin P0.
struct ScreenLine {
  bool valid = false;
  bool permute = false;          // major axis is y: coordinates stored swapped
  double P0[2], dP[2];           // (major, minor) position at s = 0 and per unit s
  double Q0[3], dQ[3], k0, dk;   // homogeneous point Q = p / w and k = 1 / w
  double s_end = 0;              // s at the (screen-clipped) end

  double z(double s) const { return (Q0[2] + dQ[2] * s) / (k0 + dk * s); }
  Vec3 point(double s) const {
    const double k = k0 + dk * s;
    return {(Q0[0] + dQ[0] * s) / k, (Q0[1] + dQ[1] * s) / k, (Q0[2] + dQ[2] * s) / k};
  }
  void screen(double s, double& xs, double& ys) const {
    const double a = P0[0] + dP[0] * s, b = P0[1] + dP[1] * s;
    xs = permute ? b : a;
    ys = permute ? a : b;
  }
  void pixel(double s, int& i, int& j) const {
    double xs, ys;
    screen(s, xs, ys);
    i = static_cast<int>(std::floor(xs));
    j = static_cast<int>(std::floor(ys));
  }
};

ScreenLine screen_line(const Mat4& m, int W, int H, const SsrRay& ray) {
  ScreenLine L;
  const Vec3 end{ray.origin[0] + ray.length * ray.dir[0], ray.origin[1] + ray.length * ray.dir[1],
                 ray.origin[2] + ray.length * ray.dir[2]};
  // Project both ends into homogeneous clip space.
  const Clip h0 = to_clip(m, ray.origin), h1 = to_clip(m, end);
  if (!(h0.w > 0) || !(h1.w > 0)) return L;
  double k0 = 1 / h0.w, k1 = 1 / h1.w;
  double Q0[3] = {ray.origin[0] * k0, ray.origin[1] * k0, ray.origin[2] * k0};
  double Q1[3] = {end[0] * k1, end[1] * k1, end[2] * k1};
  double P0[2] = {0.5 * W * (1 + h0.x * k0), 0.5 * H * (1 - h0.y * k0)};
  double P1[2] = {0.5 * W * (1 + h1.x * k1), 0.5 * H * (1 - h1.y * k1)};
  if (!(std::isfinite(P0[0]) && std::isfinite(P0[1]) && std::isfinite(P1[0]) && std::isfinite(P1[1]))) return L;
  // A pixel's point projects into that pixel. An origin off the screen (a
  // position that does not belong to its pixel, or another projection) has no
  // line to march: it could lie 2^31 pixels away (no int holds its pixel) and
  // the reference would take s_end / reference_step steps to reach the screen.
  if (!(P0[0] >= 0 && P0[0] < W && P0[1] >= 0 && P0[1] < H)) return L;
  // Clip the end to the screen rectangle (everything is affine in screen space, so
  // Q and k are cut at the same fraction): rays leaving the screen stop at its edge.
  const double lim[2] = {W - 1e-6, H - 1e-6};
  double s_max = 1;
  for (int a = 0; a < 2; ++a) {
    const double dlt = P1[a] - P0[a];
    if (dlt > 0 && P0[a] + dlt > lim[a]) s_max = std::min(s_max, (lim[a] - P0[a]) / dlt);
    if (dlt < 0 && P0[a] + dlt < 0) s_max = std::min(s_max, -P0[a] / dlt);
  }
  s_max = std::max(0.0, s_max);
  if (s_max < 1) {
    for (int a = 0; a < 2; ++a) P1[a] = P0[a] + s_max * (P1[a] - P0[a]);
    for (int a = 0; a < 3; ++a) Q1[a] = Q0[a] + s_max * (Q1[a] - Q0[a]);
    k1 = k0 + s_max * (k1 - k0);
  }
  // Keep the line from degenerating to a point (the article's 0.01 px nudge).
  if ((P1[0] - P0[0]) * (P1[0] - P0[0]) + (P1[1] - P0[1]) * (P1[1] - P0[1]) < 1e-4) P1[0] += 0.01;
  double delta[2] = {P1[0] - P0[0], P1[1] - P0[1]};
  // Step along the major axis: swap x and y for steep lines.
  if (std::abs(delta[0]) < std::abs(delta[1])) {
    L.permute = true;
    std::swap(delta[0], delta[1]);
    std::swap(P0[0], P0[1]);
  }
  const double step_dir = delta[0] > 0 ? 1.0 : -1.0;
  const double inv_dx = step_dir / delta[0];  // 1 / |delta major|
  // The origin is a pixel centre up to rounding; snap its major coordinate to it
  // exactly, so samples at (centre + jitter + n) never straddle a pixel boundary
  // through rounding (which would make the march skip or repeat a pixel).
  L.P0[0] = std::floor(P0[0]) + 0.5, L.P0[1] = P0[1];
  L.dP[0] = step_dir, L.dP[1] = delta[1] * inv_dx;
  for (int a = 0; a < 3; ++a) L.Q0[a] = Q0[a], L.dQ[a] = (Q1[a] - Q0[a]) * inv_dx;
  L.k0 = k0, L.dk = (k1 - k0) * inv_dx;
  L.s_end = std::abs(delta[0]);
  L.valid = true;
  return L;
}

SsrHit hit_on_line(const ScreenLine& L, const SsrRay& ray, double s, std::int64_t samples) {
  SsrHit h;
  h.hit = true;
  h.point = L.point(s);
  L.screen(s, h.x, h.y);
  const double dx = h.point[0] - ray.origin[0], dy = h.point[1] - ray.origin[1], dz = h.point[2] - ray.origin[2];
  const double d2 = dx * dx + dy * dy + dz * dz;
  h.distance = std::isfinite(d2) ? std::sqrt(d2) : std::hypot(dx, dy, dz);  // points beyond 1e154: no Inf square
  h.samples = samples;
  return h;
}

// Refinement predicate on the line at s (the origin pixel never counts).
bool line_behind(const SsrDepth& d, const ScreenLine& L, double s, int px, int py) {
  int i, j;
  L.pixel(s, i, j);
  if (i == px && j == py) return false;
  return depth_behind(d, i, j, L.z(s));
}

// Binary search for the crossing in [lo, hi] after a step at s hit: hi must be
// behind the surface, so take the first of s + r, s, s - r (r = half the step)
// that is; if none is (the ray only grazed the band), keep s.
double refine_on_line(const SsrDepth& d, const ScreenLine& L, double lo, double s, double r, int steps, int px,
                      int py, std::int64_t& samples) {
  double hi = s;
  const double cand[3] = {std::min(s + r, L.s_end), s, std::max(lo, s - r)};
  bool found = false;
  for (double c : cand) {
    ++samples;
    if (line_behind(d, L, c, px, py)) {
      hi = c, found = true;
      break;
    }
  }
  if (!found || !(hi > lo)) return s;
  for (int b = 0; b < steps; ++b) {
    const double mid = 0.5 * (lo + hi);
    ++samples;
    (line_behind(d, L, mid, px, py) ? hi : lo) = mid;
  }
  return hi;
}

// ---- Tracer B: McGuire-Mara DDA ----------------------------------------------------
SsrHit trace_dda(const SsrDepth& d, const Mat4& m, const SsrRay& ray, int px, int py, const SsrOptions& o,
                 std::vector<std::array<int, 2>>* visited) {
  const ScreenLine L = screen_line(m, d.width, d.height, ray);
  if (!L.valid) return no_hit(0);
  std::int64_t samples = 0;
  // Pixel stride shrinking with the origin's distance; per-pixel jitter of the start.
  const double stride = 1 + (o.stride - 1) * std::max(0.0, 1 - (-ray.origin[2]) / o.stride_z_cutoff);
  const double c = (px + py) * 0.25;
  const double s0 = o.jitter * (c - std::floor(c)) * stride;
  // Ray depth range of a sample: the part of the ray that crosses the sampled
  // pixel, half a pixel either side along the major axis (the article's zA/zB
  // at stride 1). At larger strides the article spans the whole step instead;
  // comparing several pixels' worth of ray against one pixel's depth made the
  // floor hit itself near the origin (see docs/ssr.md), so the span stays one
  // pixel and the binary search closes the gap between samples. z(s) is
  // monotone along the line, so the range is spanned by its ends. Sampling
  // starts at s0 (n = 0) so a jittered start never jumps over the pixel next to
  // the origin, and the span never reaches back into the origin pixel (|s| < 1/2).
  double s_prev = 0.5;
  for (int n = 0; n < o.max_steps; ++n) {
    const double s = s0 + n * stride;
    if (s > L.s_end) break;
    int i, j;
    L.pixel(s, i, j);
    if (i == px && j == py) {
      s_prev = s;
      continue;
    }
    const double za = L.z(std::max(0.5, s - 0.5)), zb = L.z(std::min(s + 0.5, L.s_end));
    const double zlo = std::min(za, zb), zhi = std::max(za, zb);
    if (visited) visited->push_back({i, j});
    ++samples;
    if (depth_hit(d, i, j, zlo, zhi)) {
      if (o.binary_steps <= 0) return hit_on_line(L, ray, s, samples);
      // Binary search for the crossing between the last miss and this step.
      const double sh = refine_on_line(d, L, s_prev, s, 0.5, o.binary_steps, px, py, samples);
      return hit_on_line(L, ray, sh, samples);
    }
    s_prev = s;
  }
  return no_hit(samples);
}

// ---- Reference: dense sub-pixel march on the same line -------------------------------
SsrHit trace_reference(const SsrDepth& d, const Mat4& m, const SsrRay& ray, int px, int py,
                       const SsrOptions& o, std::vector<std::array<int, 2>>* visited) {
  const ScreenLine L = screen_line(m, d.width, d.height, ray);
  if (!L.valid) return no_hit(0);
  std::int64_t samples = 0;
  const double h = o.reference_step;
  const std::int64_t count = static_cast<std::int64_t>(std::floor(L.s_end / h));
  double s_prev = 0;
  for (std::int64_t n = 1; n <= count; ++n) {
    const double s = n * h;
    int i, j;
    L.pixel(s, i, j);
    if (i == px && j == py) {
      s_prev = s;
      continue;
    }
    ++samples;
    if (visited && (visited->empty() || visited->back() != std::array<int, 2>{i, j})) visited->push_back({i, j});
    // Depth range of the sub-step around s (a ray crossing the band within one
    // sub-step still counts), then a long binary search with point tests.
    const double za = L.z(s - 0.5 * h), zb = L.z(std::min(s + 0.5 * h, L.s_end));
    if (depth_hit(d, i, j, std::min(za, zb), std::max(za, zb))) {
      const double sh = refine_on_line(d, L, s_prev, s, 0.5 * h, o.reference_binary_steps, px, py, samples);
      return hit_on_line(L, ray, sh, samples);
    }
    s_prev = s;
  }
  return no_hit(samples);
}

void check_options(const SsrOptions& o) {
  auto fail = [](const std::string& what) { throw ValueError("ssr_trace: " + what); };
  if (!(o.near > 0)) fail("options.near must be > 0");
  if (!(o.max_distance > 0) || !std::isfinite(o.max_distance)) fail("options.max_distance must be finite and > 0");
  if (!(o.thickness >= 0) || !std::isfinite(o.thickness)) fail("options.thickness must be finite and >= 0");
  if (o.max_steps < 1 || o.max_steps > (1 << 20)) fail("options.max_steps must be in [1, 2^20]");
  if (o.binary_steps < 0 || o.binary_steps > 64) fail("options.binary_steps must be in [0, 64]");
  if (!(o.stride >= 1) || !std::isfinite(o.stride)) fail("options.stride must be finite and >= 1");
  if (!(o.stride_z_cutoff > 0)) fail("options.stride_z_cutoff must be > 0");
  if (!(o.jitter >= 0 && o.jitter <= 1)) fail("options.jitter must be in [0, 1]");
  if (!(o.reference_step > 1e-4 && o.reference_step <= 1)) fail("options.reference_step must be in (1e-4, 1]");
  if (o.reference_binary_steps < 0 || o.reference_binary_steps > 64)
    fail("options.reference_binary_steps must be in [0, 64]");
  if (!(o.edge_distance > 0) || !(o.edge_exponent > 0) || !(o.fade_distance > 0) || !(o.fade_exponent > 0))
    fail("options.edge_distance, edge_exponent, fade_distance and fade_exponent must be > 0");
}

}  // namespace

bool ssr_project(const Mat4& m, int width, int height, const Vec3& p, double& xs, double& ys) {
  const Clip c = to_clip(m, p);
  if (!(c.w > 0)) return false;
  xs = 0.5 * width * (1 + c.x / c.w);
  ys = 0.5 * height * (1 - c.y / c.w);
  return std::isfinite(xs) && std::isfinite(ys);
}

SsrRay ssr_ray(const Vec3& P, const Vec3& N, double near, double max_distance) {
  SsrRay r;
  if (!finite3(P) || !finite3(N)) return r;
  const double lp = std::sqrt(P[0] * P[0] + P[1] * P[1] + P[2] * P[2]);
  const double ln = std::sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
  if (!(lp > 0) || !(ln > 1e-12) || !(P[2] < -near)) return r;
  // incident = normalize(P); reflected = I - 2 (N.I) N
  const Vec3 I{P[0] / lp, P[1] / lp, P[2] / lp}, n{N[0] / ln, N[1] / ln, N[2] / ln};
  const double ni = n[0] * I[0] + n[1] * I[1] + n[2] * I[2];
  r.dir = {I[0] - 2 * ni * n[0], I[1] - 2 * ni * n[1], I[2] - 2 * ni * n[2]};
  r.origin = P;
  // Clip to the near plane: stop where the ray reaches z = -near.
  r.length = max_distance;
  if (P[2] + r.dir[2] * max_distance > -near) r.length = (-near - P[2]) / r.dir[2];
  r.valid = r.length > 0 && std::isfinite(r.length);
  return r;
}

template <class T>
SsrDepth ssr_depth(const SsrParams<T>& p, double thickness) {
  SsrDepth d;
  d.width = p.width, d.height = p.height;
  const std::int64_t n = static_cast<std::int64_t>(p.width) * p.height;
  d.front.assign(n, -kInf);
  d.lower.assign(n, -kInf);
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t k = lo; k < hi; ++k) {
      const double z = static_cast<double>(p.position[3 * k + 2]);
      if (!p.mask[k] || !std::isfinite(z)) continue;
      d.front[k] = z;
      d.lower[k] = z - thickness;
      // A back face behind the front surface gives the real thickness.
      if (p.back_z && p.back_mask && p.back_mask[k]) {
        const double b = static_cast<double>(p.back_z[k]);
        if (std::isfinite(b) && b < z) d.lower[k] = b;
      }
    }
  });
  return d;
}

SsrHit ssr_trace_ray(const SsrDepth& depth, const Mat4& projection, const SsrRay& ray, int px, int py,
                     const SsrOptions& o, std::vector<std::array<int, 2>>* visited) {
  if (!ray.valid) return no_hit(0);
  switch (o.tracer) {
    case SsrTracer::ViewSpace: return trace_view_space(depth, projection, ray, px, py, o, visited);
    case SsrTracer::Dda: return trace_dda(depth, projection, ray, px, py, o, visited);
    case SsrTracer::Reference: return trace_reference(depth, projection, ray, px, py, o, visited);
  }
  return no_hit(0);
}

double ssr_edge_fade(double xs, double ys, int width, int height, const SsrOptions& o) {
  const double a = xs / width, b = ys / height;
  if (o.edge_form == EdgeFade::Circular) {
    const double r = 2 * std::sqrt((a - 0.5) * (a - 0.5) + (b - 0.5) * (b - 0.5));
    return std::clamp(1 - std::pow(r, o.edge_exponent), 0.0, 1.0);
  }
  const double v = o.edge_distance * a * (1 - a) * b * (1 - b);
  return std::clamp(std::pow(std::abs(v), o.edge_exponent), 0.0, 1.0);
}

double ssr_distance_fade(double distance, const SsrOptions& o) {
  return std::clamp(1 - std::pow(distance / o.fade_distance, o.fade_exponent), 0.0, 1.0);
}

template <class T>
SsrStats ssr_trace(const SsrParams<T>& p, const SsrOptions& o) {
  if (p.width < 1 || p.height < 1 || p.width > 16384 || p.height > 16384)
    throw ValueError("ssr_trace: width and height must be in 1..16384, got " + std::to_string(p.width) + " x " +
                     std::to_string(p.height));
  if (!p.position || !p.normal || !p.mask) throw ValueError("ssr_trace: position, normal and mask are required");
  for (double v : p.projection)
    if (!std::isfinite(v)) throw ValueError("ssr_trace: projection holds NaN or Inf");
  check_options(o);
  const SsrDepth depth = ssr_depth(p, o.thickness);
  const int W = p.width, H = p.height;
  std::vector<std::int64_t> row_hits(H, 0), row_samples(H, 0), row_rays(H, 0);
  parallel_for(0, H, 1, [&](std::int64_t r0, std::int64_t r1) {
    for (std::int64_t j = r0; j < r1; ++j) {
      for (int i = 0; i < W; ++i) {
        const std::int64_t k = j * W + i;
        SsrHit h;
        if (p.mask[k]) {
          ++row_rays[j];
          const Vec3 P{double(p.position[3 * k]), double(p.position[3 * k + 1]), double(p.position[3 * k + 2])};
          const Vec3 N{double(p.normal[3 * k]), double(p.normal[3 * k + 1]), double(p.normal[3 * k + 2])};
          const SsrRay ray = ssr_ray(P, N, o.near, o.max_distance);
          h = ssr_trace_ray(depth, p.projection, ray, i, static_cast<int>(j), o, nullptr);
          row_samples[j] += h.samples;
        }
        // Misses write neutral, finite values. A hit whose point or distance
        // does not fit T (max_distance 1e300 on a float32 G-buffer) is none.
        const bool hit = h.hit && fits<T>(h.x) && fits<T>(h.y) && fits<T>(h.point[0]) && fits<T>(h.point[1]) &&
                         fits<T>(h.point[2]) && fits<T>(h.distance);
        row_hits[j] += hit;
        if (p.hit) p.hit[k] = T(hit ? 1 : 0);
        if (p.hit_xy) {
          p.hit_xy[2 * k] = T(hit ? h.x : 0.5 * W);
          p.hit_xy[2 * k + 1] = T(hit ? h.y : 0.5 * H);
        }
        if (p.hit_distance) p.hit_distance[k] = T(hit ? h.distance : 0);
        if (p.hit_position)
          for (int a = 0; a < 3; ++a) p.hit_position[3 * k + a] = T(hit ? h.point[a] : 0);
        if (p.edge_fade) p.edge_fade[k] = T(hit ? ssr_edge_fade(h.x, h.y, W, H, o) : 0);
        if (p.distance_fade) p.distance_fade[k] = T(hit ? ssr_distance_fade(h.distance, o) : 0);
      }
    }
  });
  SsrStats s;
  for (int j = 0; j < H; ++j) s.rays += row_rays[j], s.hits += row_hits[j], s.samples += row_samples[j];
  return s;
}

template SsrStats ssr_trace<float>(const SsrParams<float>&, const SsrOptions&);
template SsrStats ssr_trace<double>(const SsrParams<double>&, const SsrOptions&);
template SsrDepth ssr_depth<float>(const SsrParams<float>&, double);
template SsrDepth ssr_depth<double>(const SsrParams<double>&, double);

}  // namespace gr::raster
