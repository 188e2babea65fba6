// Visibility antialiasing: classify each pixel pair next to a tri_id change
// (silhouette edge or intersection), blend, and the adjoint (formulas in
// visibility_antialias.h). Pairs are found per row in parallel and applied in
// row order; the adjoint computes per-pair contributions in parallel and adds
// them in pair order, so results are bit-identical for any thread count.
#include "raster/visibility_antialias.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "autodiff/base/parallel.h"
#include "raster/detail/guarded_math.h"
#include "raster/project.h"
#include "raster/detail/surface_walk.h"

namespace gr::raster {

namespace {

using detail::safe_inv;
using detail::Vertices;
using detail::WalkEnd;

// Depth steps smaller than this (z_ndc over one pixel pair) count as parallel
// planes: coplanar or nearly so, no crossing (its position would be noise).
constexpr double kMinDepthStep = 1e-12;
// The G-buffer decides which surface is in front at each centre; the planes
// here can round the other way by a few ulps where the crossing passes
// through a centre. Differences within this of zero count as that tie, so the
// crossing is still found (at t = 0 or 1) and the image stays continuous.
constexpr double kDepthTie = 1e-12;

// The plane of a triangle's z_ndc over the screen: z(c) = z0 + a (cx - x0) +
// b (cy - y0), and the screen barycentrics lambda_k(c).
struct DepthPlane {
  double x0, y0, z0, a, b;
  double ex1, ey1, ex2, ey2, inv_d;  // edge vectors from vertex 0, 1 / (2 area)
  double at(double cx, double cy) const { return z0 + a * (cx - x0) + b * (cy - y0); }
  void barycentrics(double cx, double cy, double* l) const {
    const double dx = cx - x0, dy = cy - y0;
    l[1] = (dx * ey2 - dy * ex2) * inv_d;
    l[2] = (ex1 * dy - ey1 * dx) * inv_d;
    l[0] = 1.0 - l[1] - l[2];
  }
};

DepthPlane depth_plane(const Vertices& v, const std::int32_t* tri) {
  const double* s0 = &v.screen[3 * static_cast<std::size_t>(tri[0])];
  const double* s1 = &v.screen[3 * static_cast<std::size_t>(tri[1])];
  const double* s2 = &v.screen[3 * static_cast<std::size_t>(tri[2])];
  DepthPlane p;
  p.x0 = s0[0], p.y0 = s0[1], p.z0 = s0[2];
  p.ex1 = s1[0] - s0[0], p.ey1 = s1[1] - s0[1];
  p.ex2 = s2[0] - s0[0], p.ey2 = s2[1] - s0[1];
  p.inv_d = safe_inv(p.ex1 * p.ey2 - p.ex2 * p.ey1);  // degenerate: large, finite
  const double dz1 = s1[2] - s0[2], dz2 = s2[2] - s0[2];
  p.a = (dz1 * p.ey2 - dz2 * p.ey1) * p.inv_d;
  p.b = (p.ex1 * dz2 - p.ex2 * dz1) * p.inv_d;
  return p;
}

double centre_x(std::int64_t pixel, int w) { return double(pixel % w) + 0.5; }
double centre_y(std::int64_t pixel, int w) { return double(pixel / w) + 0.5; }

bool all_front(const Vertices& v, const std::int32_t* tri) {
  return v.front[tri[0]] && v.front[tri[1]] && v.front[tri[2]];
}

// Where two surfaces that both cover the segment from c_f to c_b (walk paths
// from either end) cross in depth: t from c_f, the two triangles there and
// the crossing line's screen direction; t < 0 if they do not cross.
struct Crossing {
  double t = -1.0;
  std::int64_t tri_f = -1, tri_b = -1;
  double direction_x = 0, direction_y = 0;
};

Crossing first_crossing(const Vertices& v, const std::int32_t* tris, const detail::WalkPath& pf,
                        const detail::WalkPath& pb, double fx, double fy, double bx, double by) {
  // Piece boundaries in t: the front path's entries, and 1 - s of the other's.
  int i = 0, j = pb.count - 1;  // the other path, walked from c_b, covers t near 0 with its last triangle
  double lo = 0.0;
  while (i < pf.count && j >= 0) {
    const double end_f = i + 1 < pf.count ? pf.t[i + 1] : 1.0;
    const double end_b = 1.0 - pb.t[j];
    const double hi = std::min(end_f, end_b);
    const std::int32_t* trf = tris + 3 * pf.tri[i];
    const std::int32_t* trb = tris + 3 * pb.tri[j];
    if (all_front(v, trf) && all_front(v, trb)) {
      const DepthPlane a = depth_plane(v, trf), b = depth_plane(v, trb);
      // d is affine along the whole segment for this pair: its values at the centres.
      const double d0 = a.at(fx, fy) - b.at(fx, fy), d1 = a.at(bx, by) - b.at(bx, by);
      const double dlo = d0 + lo * (d1 - d0), dhi = d0 + hi * (d1 - d0);
      // Equality at a centre (d0 = 0 or d1 = 0, to kDepthTie) is a crossing at t = 0 or 1.
      if (dlo <= kDepthTie && dhi >= -kDepthTie && d1 - d0 > kMinDepthStep) {
        Crossing x;
        x.t = std::clamp(d0 / (d0 - d1), lo, hi);
        x.tri_f = pf.tri[i], x.tri_b = pb.tri[j];
        x.direction_x = a.b - b.b, x.direction_y = -(a.a - b.a);
        return x;
      }
    }
    lo = hi;
    if (end_f <= end_b) ++i;
    if (end_b <= end_f) --j;
  }
  return {};
}

}  // namespace

// ---------------------------------------------------------------------------
// Forward

template <class T>
void visibility_antialias_forward(const VisibilityAntialiasParams<T>& prm, T* out,
                                  std::vector<VisibilityPair>* pairs_out, VisibilityAntialiasStats* stats) {
  assert(prm.width >= 1 && prm.height >= 1 && prm.channels >= 1 && prm.topology &&
         prm.topology->num_tris() == prm.num_tris);
  const T *image = prm.image, *depth = prm.depth;
  const std::int32_t *tri_id = prm.tri_id, *tris = prm.tris;
  const EdgeTopology& topology = *prm.topology;
  const int W = prm.width, H = prm.height, C = prm.channels;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;
  const Vertices v = detail::project_vertices(prm.clip, prm.num_vertices, W, H, prm.y_up);
  detail::SurfaceSides sides(prm.num_tris);

  parallel_for(0, P * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    std::copy(image + lo, image + hi, out + lo);
  });

  auto edge_pair = [&](std::int64_t in, std::int64_t outp, const WalkEnd& e, bool horizontal,
                       std::vector<VisibilityPair>& found) {
    const double* sa = &v.screen[3 * static_cast<std::size_t>(e.a)];
    const double* sb = &v.screen[3 * static_cast<std::size_t>(e.b)];
    if (!detail::pair_owns_direction(horizontal, sb[0] - sa[0], sb[1] - sa[1])) return;
    VisibilityPair pr{in, outp, BoundaryKind::Edge, {e.a, e.b, -1, -1, -1, -1}, e.t};
    found.push_back(pr);
  };

  // The pair (p, q): which boundary lies between the centres (header, steps 1-3).
  auto evaluate = [&](std::int64_t p, std::int64_t q, bool horizontal, std::vector<VisibilityPair>& found) {
    const std::int32_t ip = tri_id[p], iq = tri_id[q];
    const bool p_front = iq == 0 || (ip != 0 && (depth[p] < depth[q] || (depth[p] == depth[q] && ip < iq)));
    const std::int64_t f = p_front ? p : q, b = p_front ? q : p;
    const std::int64_t tf = (p_front ? ip : iq) - 1, tb = (p_front ? iq : ip) - 1;  // tb < 0: background
    const double fx = centre_x(f, W), fy = centre_y(f, W), bx = centre_x(b, W), by = centre_y(b, W);
    // 1. The front surface, towards the other centre.
    detail::WalkPath path_f, path_b;
    const WalkEnd wf = detail::walk_surface(v, tris, topology, W, H, tf, tb, fx, fy, bx, by, &path_f, &sides);
    if (wf.kind == WalkEnd::Kind::Silhouette) return edge_pair(f, b, wf, horizontal, found);
    if (wf.kind != WalkEnd::Kind::Continues || tb < 0) return;
    // 2. The front surface goes on under the other: follow the other back.
    const WalkEnd wb = detail::walk_surface(v, tris, topology, W, H, tb, tf, bx, by, fx, fy, &path_b, &sides);
    if (wb.kind == WalkEnd::Kind::Silhouette) return edge_pair(b, f, wb, horizontal, found);
    if (wb.kind != WalkEnd::Kind::Continues) return;
    // 3. Both go on under each other: both are piecewise planar along the
    // segment (the walks' triangles); find the first piece, with one triangle
    // of each, on which their depth difference goes from <= 0 to >= 0.
    const Crossing x = first_crossing(v, tris, path_f, path_b, fx, fy, bx, by);
    if (x.t < 0.0) return;
    // The crossing line's direction is perpendicular to the gradient of d.
    if (!detail::pair_owns_direction(horizontal, x.direction_x, x.direction_y)) return;
    const std::int32_t* trf = tris + 3 * x.tri_f;
    const std::int32_t* trb = tris + 3 * x.tri_b;
    found.push_back({f, b, BoundaryKind::Intersection, {trf[0], trf[1], trf[2], trb[0], trb[1], trb[2]}, x.t});
  };

  std::vector<std::vector<VisibilityPair>> rows;
  const std::int64_t candidates = detail::for_each_id_boundary(tri_id, W, H, rows, evaluate);

  // Apply in row order (a pixel can be written by up to four pairs).
  std::size_t total = 0;
  std::int64_t crossings = 0;
  for (const auto& r : rows) total += r.size();
  if (pairs_out) pairs_out->reserve(pairs_out->size() + total);
  for (const auto& r : rows)
    for (const VisibilityPair& pr : r) {
      detail::apply_blend(detail::blend_step(pr), image, out, C);
      crossings += pr.kind == BoundaryKind::Intersection;
      if (pairs_out) pairs_out->push_back(pr);
    }
  if (stats) {
    stats->candidate_pairs = candidates;
    stats->intersection_pairs = crossings;
    stats->edge_pairs = static_cast<std::int64_t>(total) - crossings;
  }
}

// ---------------------------------------------------------------------------
// Adjoint

template <class T>
void visibility_antialias_backward(const VisibilityAntialiasParams<T>& prm, const std::vector<VisibilityPair>& pairs,
                                   const T* grad_out, const AntialiasGrads<T>& grads) {
  T* grad_image = grads.image;
  T* grad_clip = grads.clip;
  const T* image = prm.image;
  const int W = prm.width, H = prm.height, C = prm.channels;
  const std::int64_t P = static_cast<std::int64_t>(W) * H;
  const std::int64_t n_pairs = static_cast<std::int64_t>(pairs.size());
  // Colours: identity plus the blend weights, in pair order.
  if (grad_image) detail::blend_image_adjoint(pairs, grad_out, grad_image, P, C);
  if (!grad_clip || n_pairs == 0) return;

  // Per pair: screen (x, y, z_ndc) gradients of up to six vertices, in parallel ...
  const Vertices v = detail::project_vertices(prm.clip, prm.num_vertices, W, H, prm.y_up);
  std::vector<double> contrib(static_cast<std::size_t>(18 * n_pairs), 0.0);
  std::vector<std::uint8_t> live(static_cast<std::size_t>(n_pairs), 0);
  parallel_for(0, n_pairs, 2048, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const VisibilityPair& pr = pairs[i];
      const std::int64_t target = detail::blend_step(pr).target;
      // dL/dt = g[target] . (image[inside] - image[outside]); zero: skip.
      double gt = 0.0;
      for (int c = 0; c < C; ++c)
        gt += double(grad_out[target * C + c]) * (double(image[pr.inside * C + c]) - double(image[pr.outside * C + c]));
      if (gt == 0.0) continue;
      const double cix = centre_x(pr.inside, W), ciy = centre_y(pr.inside, W);
      const double cox = centre_x(pr.outside, W), coy = centre_y(pr.outside, W);
      double* o = &contrib[18 * i];
      if (pr.kind == BoundaryKind::Edge) {
        // t = E_i / (E_i - E_o): quotient rule, then dE/d(endpoints).
        const double* sa = &v.screen[3 * static_cast<std::size_t>(pr.v[0])];
        const double* sb = &v.screen[3 * static_cast<std::size_t>(pr.v[1])];
        const double ei = detail::edge_fn(cix, ciy, sa, sb), eo = detail::edge_fn(cox, coy, sa, sb);
        const double inv_d = safe_inv(ei - eo);
        const double g_ei = -eo * inv_d * inv_d * gt, g_eo = ei * inv_d * inv_d * gt;
        o[0] = g_ei * (ciy - sb[1]) + g_eo * (coy - sb[1]);
        o[1] = g_ei * (sb[0] - cix) + g_eo * (sb[0] - cox);
        o[3] = g_ei * (sa[1] - ciy) + g_eo * (sa[1] - coy);
        o[4] = g_ei * (cix - sa[0]) + g_eo * (cox - sa[0]);
      } else {
        // t = d0 / (d0 - d1), d_j = z_F(c_j) - z_B(c_j).
        const DepthPlane pf = depth_plane(v, pr.v), pb = depth_plane(v, pr.v + 3);
        const double d0 = pf.at(cix, ciy) - pb.at(cix, ciy), d1 = pf.at(cox, coy) - pb.at(cox, coy);
        const double inv = safe_inv(d0 - d1);
        const double g0 = -d1 * inv * inv * gt, g1 = d0 * inv * inv * gt;
        // dz(c)/dz_k = lambda_k(c), dz(c)/dx_k = -a lambda_k(c), dz(c)/dy_k = -b lambda_k(c).
        const DepthPlane* planes[2] = {&pf, &pb};
        for (int s = 0; s < 2; ++s) {
          const DepthPlane& pl = *planes[s];
          const double sign = s == 0 ? 1.0 : -1.0;
          double l0[3], l1[3];
          pl.barycentrics(cix, ciy, l0);
          pl.barycentrics(cox, coy, l1);
          for (int k = 0; k < 3; ++k) {
            const double gz = sign * (g0 * l0[k] + g1 * l1[k]);
            double* ok = o + 3 * (3 * s + k);
            ok[0] = -pl.a * gz;
            ok[1] = -pl.b * gz;
            ok[2] = gz;
          }
        }
      }
      live[i] = 1;
    }
  });
  // ... added per vertex in pair order (deterministic).
  std::vector<double> acc(static_cast<std::size_t>(3 * prm.num_vertices), 0.0);
  bool any = false;
  for (std::int64_t i = 0; i < n_pairs; ++i) {
    if (!live[i]) continue;
    any = true;
    const VisibilityPair& pr = pairs[i];
    const int count = pr.kind == BoundaryKind::Edge ? 2 : 6;
    for (int k = 0; k < count; ++k)
      for (int c = 0; c < 3; ++c) acc[3 * static_cast<std::size_t>(pr.v[k]) + c] += contrib[18 * i + 3 * k + c];
  }
  if (!any) return;
  // Screen x, y and z_ndc -> clip (every vertex used has w > 0).
  screen_to_clip_backward(prm.clip, prm.num_vertices, W, H, acc.data(), 3, grad_clip, prm.y_up);
}

#define GR_INSTANTIATE(T)                                                                                   \
  template void visibility_antialias_forward<T>(const VisibilityAntialiasParams<T>&, T*,                    \
                                                std::vector<VisibilityPair>*, VisibilityAntialiasStats*);  \
  template void visibility_antialias_backward<T>(const VisibilityAntialiasParams<T>&,                       \
                                                 const std::vector<VisibilityPair>&, const T*,             \
                                                 const AntialiasGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
