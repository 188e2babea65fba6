#version 460
// The adjoint of antialias_forward (raster/antialias.cpp, antialias_backward).
// Pass 0, per pixel p: dL/dimage[p] = g[p], then in pair order -w g[p] where
// p is a pair's target and +w g[target] where it is its source
// (blend_image_adjoint, raster/detail/surface_walk.h); and the largest screen
// contribution. Pass 1, per pixel: its two slots' contributions to the edge
// vertices' screen positions, summed in fixed point (fixed_point.glsl):
//   dL/dt = g[target] . (image[inside] - image[outside])
//   t = E_i / (E_i - E_o): dt/dE_i = -E_o / D^2, dt/dE_o = E_i / D^2
//   dE/dax = qy - by, dE/day = bx - qx, dE/dbx = ay - qy, dE/dby = qx - ax.
// With P.visibility, the pairs are visibility_pairs.comp's and the sums are
// N x 3 (screen x, y, z_ndc); a crossing (visibility_antialias_backward,
// raster/visibility_antialias.cpp) goes to the six vertices of its two planes:
//   t = d0 / (d0 - d1): dt/dd0 = -d1 / (d0 - d1)^2, dt/dd1 = d0 / (d0 - d1)^2
//   dz(c)/dz_k = lambda_k(c), dz(c)/dx_k = -a lambda_k(c), dz(c)/dy_k = -b lambda_k(c)
// (+ for the inside surface's plane, - for the outside's).
#include "dispatch.glsl"
#include "antialias_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 1) readonly buffer TriBuf { int tris[]; };
#include "depth_plane.glsl"

layout(std430, binding = 3) readonly buffer GradOutBuf { float grad_out[]; };
layout(std430, binding = 4) writeonly buffer GradImageBuf { float grad_image[]; };
// Fixed-point sums of dL/dscreen: N x 2 (x, y), or N x 3 (x, y, z_ndc) with P.visibility.
layout(std430, binding = 5) buffer SumBuf { int64_t sums[]; };
layout(std430, binding = 7) readonly buffer PairBuf { Pair pairs[]; };

void image_gradient(int p) {
  int C = P.channels;
  // The pairs p takes part in (at most four), in pair order.
  Blend blends[4];
  int n = 0;
  ivec4 slots = slots_of(p);
  for (int i = 0; i < 4; ++i) {
    int s = slots[i];
    if (s < 0 || pairs[s].a < 0) continue;
    Blend b = blend_step(s, pairs[s]);
    if (b.target == p || b.source == p) blends[n++] = b;
  }
  for (int ch = 0; ch < C; ++ch) {
    precise float gi = grad_out[p * C + ch];
    for (int i = 0; i < n; ++i) {
      double g = double(grad_out[blends[i].target * C + ch]);
      if (g == 0.0) continue;
      precise double wg = blends[i].w * g;
      gi = blends[i].target == p ? gi - float(wg) : gi + float(wg);
    }
    grad_image[p * C + ch] = gi;
  }
}

int sum_stride() { return P.visibility != 0 ? 3 : 2; }

void add_screen(int vertex, int axis, double x, int shift) {
  if (P.pass == 0)
    note_magnitude(0, x);
  else if (x != 0.0)
    atomicAdd(sums[sum_stride() * vertex + axis], to_fixed(x, shift));
}

// One plane's share of a crossing: d = z_inside - z_outside takes it with
// `sign`; g0, g1 = dL/dd at the two centres.
void plane_gradient(int t, DepthPlane pl, double sign, dvec2 ci, dvec2 co, double g0, double g1, int shift) {
  dvec3 l0 = plane_barycentrics(pl, ci), l1 = plane_barycentrics(pl, co);
  for (int k = 0; k < 3; ++k) {
    precise double gz = sign * (g0 * l0[k] + g1 * l1[k]);
    precise double gx = -pl.a * gz;
    precise double gy = -pl.b * gz;
    int v = tris[3 * t + k];
    add_screen(v, 0, gx, shift);
    add_screen(v, 1, gy, shift);
    add_screen(v, 2, gz, shift);
  }
}

// A crossing's contributions: t = d0 / (d0 - d1) over the planes of triangles
// a (inside's surface, +) and b (outside's, -).
void crossing_gradient(Pair pr, dvec2 ci, dvec2 co, double gt, int shift) {
  int ta = pr.a, tb = pair_b(pr);
  DepthPlane pa = depth_plane(ta), pb = depth_plane(tb);
  precise double d0 = plane_at(pa, ci) - plane_at(pb, ci);
  precise double d1 = plane_at(pa, co) - plane_at(pb, co);
  precise double denom = d0 - d1;
  double inv = safe_inv(denom);
  precise double g0 = -d1 * inv * inv * gt;
  precise double g1 = d0 * inv * inv * gt;
  plane_gradient(ta, pa, 1.0, ci, co, g0, g1, shift);
  plane_gradient(tb, pb, -1.0, ci, co, g0, g1, shift);
}

// Slot s's contributions to its edge's two vertices (or a crossing's six).
void clip_gradient(int s, int shift) {
  Pair pr = pairs[s];
  if (pr.a < 0) return;
  int C = P.channels;
  ivec2 io = inside_outside(s, pr);
  int target = blend_step(s, pr).target;
  precise double gt = 0.0;
  for (int ch = 0; ch < C; ++ch)
    gt += double(grad_out[target * C + ch]) * (double(image[io.x * C + ch]) - double(image[io.y * C + ch]));
  if (gt == 0.0) return;
  dvec2 ci = centre(io.x), co = centre(io.y);
  if (pair_is_crossing(pr)) {
    crossing_gradient(pr, ci, co, gt, shift);
    return;
  }
  int a = pr.a, b = pair_b(pr);
  dvec2 sa = screen_of(a), sb = screen_of(b);
  double ei = edge_fn(ci, sa, sb), eo = edge_fn(co, sa, sb);
  precise double d = ei - eo;
  double inv_d = safe_inv(d);
  precise double g_ei = -eo * inv_d * inv_d * gt;
  precise double g_eo = ei * inv_d * inv_d * gt;
  precise double gax = g_ei * (ci.y - sb.y) + g_eo * (co.y - sb.y);
  precise double gay = g_ei * (sb.x - ci.x) + g_eo * (sb.x - co.x);
  precise double gbx = g_ei * (sa.y - ci.y) + g_eo * (sa.y - co.y);
  precise double gby = g_ei * (ci.x - sa.x) + g_eo * (co.x - sa.x);
  add_screen(a, 0, gax, shift);
  add_screen(a, 1, gay, shift);
  add_screen(b, 0, gbx, shift);
  add_screen(b, 1, gby, shift);
}

// This invocation's contributions (pass 0: their magnitudes; pass 1: their sums).
void contribute() {
  int p = linear_id();
  int pixels = P.width * P.height;
  if (p >= pixels) return;
  if (P.pass == 0) image_gradient(p);
  int shift = P.pass == 0 ? 0 : fixed_point_shift(0, contributions_per_element());
  clip_gradient(2 * p, shift);
  clip_gradient(2 * p + 1, shift);
}

void main() {
  contribute();
  if (P.pass == 0) publish_magnitudes();
}
