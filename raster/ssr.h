// Screen-space reflection tracers on plain arrays (no tape): given a view-space
// G-buffer (position, normal, coverage) and the projection matrix, find for every
// pixel where its mirror ray hits the depth buffer. Three tracers share one hit
// test and one output layout:
//  - ViewSpace (tracer A): a fixed number of equal steps in view space from the
//    ray origin to its end, each projected to a pixel and compared with the scene
//    depth there within a thickness band, then a binary search (the basic SSR of
//    the article, section 1).
//  - Dda (tracer B): McGuire-Mara screen-space DDA (article section 2). Both ends
//    are projected; Q/w, 1/w and the screen position are linear in screen space
//    (perspective-correct interpolation, article appendix A), so the march steps
//    `stride` pixels along the major axis and tests the ray's depth range over
//    each step against the pixel it lands on; binary search at the end; the hit
//    point is Q/w / (1/w).
//  - Reference: the same perspective-correct screen-space line marched in steps
//    of a fraction of a pixel (reference_step, 0.05 px by default) with a long
//    binary search: slow, used by tests and the benchmark as ground truth.
//
// Conventions: OpenGL view space (camera at the origin looking down -z, so
// visible points have z < 0); projection p_clip = M p (column vectors, M row-
// major); screen xs = W/2 (1 + x_ndc), ys = H/2 (1 - y_ndc), y down, pixel (i, j)
// covers [i, i+1) x [j, j+1) with its centre at (i + 0.5, j + 0.5).
//
// Ray set-up (per covered pixel): incident I = normalize(P), R = reflect(I, N) =
// I - 2 (N.I) N, length = max_distance, or (-near - P.z) / R.z when the end would
// cross the near plane z = -near. Hit test at pixel q for a ray depth interval
// [z_lo, z_hi]: q covered and z_lo <= front(q) and z_hi >= lower(q), where
// front(q) is the scene's view z and lower(q) = front(q) - thickness, or the
// back-face depth at q when a back-face buffer is given and lies behind front(q)
// (real thickness for closed objects). Point tests use z_lo = z_hi = z.
//
// Outputs are per pixel, all plain values; a pixel without a hit (background
// pixel, ray leaving the screen, ray toward the camera with nothing in front,
// ray that hits nothing, a point whose projection is off the screen, i.e. not
// its pixel's, a hit whose point or distance does not fit T) has hit = 0,
// hit_xy = the screen centre, distance 0, fades 0, hit_position 0, so every
// output is finite.
// Fades (article 1.4, 1.5), with (a, b) = hit_xy / (W, H) in [0, 1]:
//   edge, circular: saturate(1 - (2 |(a, b) - 1/2|)^edge_exponent)
//   edge, vignette: saturate((edge_distance a (1 - a) b (1 - b))^edge_exponent)
//   distance:       saturate(1 - (d / fade_distance)^fade_exponent), d = |hit - P|.
//
// Determinism: every pixel is traced independently (parallel over rows, disjoint
// writes), so results are bit-identical for any thread count.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace gr::raster {

enum class SsrTracer { ViewSpace, Dda, Reference };
enum class EdgeFade { Circular, Vignette };

struct SsrOptions {
  SsrTracer tracer = SsrTracer::Dda;
  double near = 0.1;            // near plane distance (> 0): rays are clipped to z = -near
  double max_distance = 10.0;   // ray length limit in view-space units
  double thickness = 0.2;       // depth band behind a surface that counts as a hit
  // ViewSpace: the fixed step count. Dda: the maximum number of steps.
  int max_steps = 64;
  int binary_steps = 4;         // binary-search refinement iterations (0 = none)
  // Dda only. Pixel stride at the camera (>= 1); it shrinks linearly to 1 at
  // view depth stride_z_cutoff: stride' = 1 + (stride - 1) max(0, 1 - (-P.z)/cutoff).
  double stride = 1.0;
  double stride_z_cutoff = 100.0;
  // Dda only. Start offset in steps: jitter * frac((i + j) / 4) for pixel (i, j).
  double jitter = 0.0;
  // Reference only: step in pixels along the major axis, and bisection count.
  double reference_step = 0.05;
  int reference_binary_steps = 30;
  // Fades (plain values here; ops/render/ssr.h recomputes them on the tape).
  EdgeFade edge_form = EdgeFade::Circular;
  double edge_distance = 16.0;
  double edge_exponent = 2.0;
  double fade_distance = 10.0;
  double fade_exponent = 2.0;
};

// Inputs and outputs of one trace. Inputs are H x W (x 3) row-major arrays of T;
// outputs may be null (not written).
template <class T>
struct SsrParams {
  int width = 0, height = 0;
  std::array<double, 16> projection{};  // row-major 4 x 4, p_clip = M p
  const T* position = nullptr;          // in:  H x W x 3 view-space positions
  const T* normal = nullptr;            // in:  H x W x 3 view-space normals (unit length)
  const std::int32_t* mask = nullptr;   // in:  H x W, non-zero = covered (e.g. tri_id)
  const T* back_z = nullptr;            // in, optional: H x W view z of the nearest back face
  const std::int32_t* back_mask = nullptr;  // in, with back_z: H x W, non-zero = back face present
  T* hit = nullptr;                     // out: H x W, 1 hit / 0 none
  T* hit_xy = nullptr;                  // out: H x W x 2 screen position (pixels) of the hit
  T* hit_distance = nullptr;            // out: H x W, |hit point - P| in view space
  T* hit_position = nullptr;            // out: H x W x 3 view-space hit point
  T* edge_fade = nullptr;               // out: H x W
  T* distance_fade = nullptr;           // out: H x W
};

struct SsrStats {
  std::int64_t rays = 0;         // covered pixels traced
  std::int64_t hits = 0;
  std::int64_t samples = 0;      // depth-buffer lookups, binary search included
};

// Traces every pixel. Throws ValueError for bad sizes or options (message names them).
template <class T>
SsrStats ssr_trace(const SsrParams<T>& params, const SsrOptions& options);

// ---- Single-ray interface (tests, debugging) --------------------------------

// The scene depth the tracers compare against: per pixel front(q) and lower(q)
// (see the header comment), -inf front for uncovered pixels.
struct SsrDepth {
  int width = 0, height = 0;
  std::vector<double> front, lower;
};
template <class T>
SsrDepth ssr_depth(const SsrParams<T>& params, double thickness);

struct SsrRay {
  bool valid = false;  // false for a degenerate normal or a zero-length ray
  std::array<double, 3> origin{}, dir{};
  double length = 0;
};
// Reflection ray of a view-space point P with normal N, clipped to the near plane.
SsrRay ssr_ray(const std::array<double, 3>& P, const std::array<double, 3>& N, double near,
               double max_distance);

struct SsrHit {
  bool hit = false;
  double x = 0, y = 0;                     // screen position of the hit point
  std::array<double, 3> point{};           // view-space hit point
  double distance = 0;
  std::int64_t samples = 0;
};
// Traces one ray that starts at pixel (px, py). With `visited`, every pixel the
// march tests (before the binary search) is appended, in order.
SsrHit ssr_trace_ray(const SsrDepth& depth, const std::array<double, 16>& projection, const SsrRay& ray,
                     int px, int py, const SsrOptions& options,
                     std::vector<std::array<int, 2>>* visited = nullptr);

// Screen position (pixels) of a view-space point; false if w <= 0.
bool ssr_project(const std::array<double, 16>& projection, int width, int height,
                 const std::array<double, 3>& p, double& xs, double& ys);

// The fades as plain values (see the header comment); `distance` in view units.
double ssr_edge_fade(double xs, double ys, int width, int height, const SsrOptions& options);
double ssr_distance_fade(double distance, const SsrOptions& options);

}  // namespace gr::raster
