// Attribute interpolation forward and adjoint. Both loop over pixels (image
// form) or fragments (fragment form: the covered pixels only, in ascending
// pixel order) in parallel, through the same per-item loops. The adjoint sums
// each triangle's items in item order (parallel over triangles), then each
// vertex its triangles' corner sums in the order of the triangles' first items
// (parallel over vertices): gradients depend neither on the thread count nor on
// the triangle order, and the two forms give bit-identical results
// (docs/determinism.md, "Scatter by gathering").
#include "raster/interpolate.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/buckets.h"
#include "raster/detail/corner_gather.h"
#include "raster/detail/guarded_math.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/triangle_groups.h"

namespace gr::raster {
namespace {

using detail::safe_inv;

// Smallest w taken as in front for the weights lambda_k / w_k: below it 1/w_k
// is not meaningful (safe_inv's 1e-30 guard shifts it by more than 1e-16 of its
// value) and the rasterizer's barycentrics themselves may have saturated.
constexpr double kMinFrontW = 1e-14;

// A triangle takes the homogeneous (clipped) form, exact at any w, when a vertex
// is not in front: rasterize's near-plane test (w > 0, z >= -w; see
// detail::project_vertices), or a w too close to the eye plane for 1/w.
template <class T>
bool behind_near_plane(const T* c) {
  const double z = c[2], w = c[3];
  return !(w > kMinFrontW && z >= -w);
}

template <class T>
bool is_clipped(const T* clip, const std::int32_t* tri) {
  for (int k = 0; k < 3; ++k)
    if (behind_near_plane(clip + 4 * static_cast<std::int64_t>(tri[k]))) return true;
  return false;
}

// Whether any vertex is behind (so some triangle may be clipped).
template <class T>
bool any_vertex_behind(const T* clip, std::int64_t num_vertices) {
  for (std::int64_t i = 0; i < num_vertices; ++i)
    if (behind_near_plane(clip + 4 * i)) return true;
  return false;
}

// Per-call facts the per-pixel math needs besides the triangle: where item p
// lies (pixel p of a width x height image, or pixel pixel_index[p] for
// fragments), and whether any vertex is behind the near plane (if none, no
// triangle is clipped and the per-pixel test is skipped).
struct Items {
  int width, height;
  const std::int32_t* pixel_index;  // null: item p is pixel p
  bool any_behind;
  // Centre e = (col + 0.5, row + 0.5, 1) of item p's pixel.
  detail::HVec centre(std::int64_t p) const {
    const std::int64_t pixel = pixel_index ? static_cast<std::int64_t>(pixel_index[p]) : p;
    return {static_cast<double>(pixel % width) + 0.5, static_cast<double>(pixel / width) + 0.5, 1.0};
  }
};

template <class T>
Items make_items(const InterpolateParams<T>& p) {
  return {p.width, p.height, p.pixel_index, any_vertex_behind(p.clip, p.num_vertices)};
}

// Homogeneous screen vertices V_k = (W/2 (x_k + w_k), H/2 (w_k - y_k), w_k).
template <class T>
void homogeneous_vertices(const T* clip, const std::int32_t* tri, int width, int height, detail::HVec* V) {
  for (int k = 0; k < 3; ++k) {
    const T* v = clip + 4 * static_cast<std::int64_t>(tri[k]);
    V[k] = {0.5 * width * (double(v[0]) + v[3]), 0.5 * height * (double(v[3]) - v[1]), double(v[3])};
  }
}

// Weights of the three vertices at one pixel: A = sum_k weight_k A_k.
// Perspective: q_k = lambda_k / w_k, s = sum q_k, weight_k = q_k / s; also
// returns q_k and 1/s for the adjoint. Clipped triangles take q_k from the clip
// positions and the pixel centre e instead: q_k = F_k / D with
// F_k = e . (V_k+1 x V_k+2), D = V_0 . (V_1 x V_2) (docs/rasterizer.md). That is
// the same value (rasterize stores lambda_k = w_k F_k / D), but it stays exact
// at w_k = 0, where lambda_k = 0 and lambda_k / w_k loses the vertex's weight.
//
// The part that does not depend on the pixel (1/w_k, or V_k, the cross products
// and 1/D) is TriangleWeights, computed once per triangle by the adjoint's
// per-triangle walk; pixel_weights finishes it for one pixel. Same arithmetic
// in the same order either way, so the forward and the adjoint agree bit for bit.
struct TriangleWeights {
  bool perspective = true;
  bool from_clip = false;    // q_k = F_k / D; then V, cr and inv_d are set
  double inv_w[3];           // perspective, not from_clip: 1 / w_k
  detail::HVec V[3], cr[3];  // from_clip: V_k and V_k+1 x V_k+2
  double inv_d;              // from_clip: 1 / D
};

template <class T>
TriangleWeights triangle_weights(const T* clip, const std::int32_t* tri, bool perspective, const Items& items) {
  TriangleWeights tw;
  tw.perspective = perspective;
  if (!perspective) return tw;
  if (items.any_behind && is_clipped(clip, tri)) {
    tw.from_clip = true;
    homogeneous_vertices(clip, tri, items.width, items.height, tw.V);
    tw.inv_d = safe_inv(detail::dot(tw.V[0], detail::cross(tw.V[1], tw.V[2])));
    for (int k = 0; k < 3; ++k) tw.cr[k] = detail::cross(tw.V[(k + 1) % 3], tw.V[(k + 2) % 3]);
  } else {
    for (int k = 0; k < 3; ++k) tw.inv_w[k] = safe_inv(static_cast<double>(clip[4 * static_cast<std::int64_t>(tri[k]) + 3]));
  }
  return tw;
}

// weight_k = q_k / s, s = q_0 + q_1 + q_2 summed from 0 in that order (one
// formula for the per-item and the vectorized loops, so they agree bit for
// bit); returns 1 / s (guarded). Always inlined: otherwise GCC 12 no longer
// vectorizes the adjoint's lane loop.
[[gnu::always_inline]] inline double weights_from(const double* q, double* weight) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) s += q[k];
  const double inv_s = safe_inv(s);
  for (int k = 0; k < 3; ++k) weight[k] = q[k] * inv_s;
  return inv_s;
}

struct PixelWeights {
  double lambda[3], weight[3], q[3], inv_s;
  detail::HVec e;  // from_clip: the pixel centre
};

template <class T>
inline PixelWeights pixel_weights(const TriangleWeights& tw, const T* uv, const Items& items, std::int64_t p) {
  PixelWeights pw;
  const double u = uv[2 * p], v = uv[2 * p + 1];
  pw.lambda[0] = 1.0 - u - v;
  pw.lambda[1] = u;
  pw.lambda[2] = v;
  if (!tw.perspective) {
    for (int k = 0; k < 3; ++k) pw.weight[k] = pw.lambda[k];
    return pw;
  }
  if (tw.from_clip) {
    // q_k = F_k / D.
    pw.e = items.centre(p);
    for (int k = 0; k < 3; ++k) pw.q[k] = detail::dot(pw.e, tw.cr[k]) * tw.inv_d;
  } else {
    // q_k = lambda_k / w_k.
    for (int k = 0; k < 3; ++k) pw.q[k] = pw.lambda[k] * tw.inv_w[k];
  }
  pw.inv_s = weights_from(pw.q, pw.weight);
  return pw;
}

// Both parts for one pixel (the forward and the derivatives, which walk pixels).
template <class T>
PixelWeights pixel_weights(const T* clip, const std::int32_t* tri, const T* uv, bool perspective,
                           const Items& items, std::int64_t p) {
  return pixel_weights(triangle_weights(clip, tri, perspective, items), uv, items, p);
}

// Adjoint of q_k = F_k / D (clipped triangles) for dL/dq_k = G_k, written as
// dL/d(x, y, w) of the three vertices to xyw[3k..3k+2]. dL/dD = -sum_k G_k q_k / D
// is 0 (G_k = g . (A_k - A) / s and sum_k q_k (A_k - A) = 0), so only
// dL/dF_k = G_k / D is propagated: dF_k/dV_a = V_b x e, dF_k/dV_b = e x V_a
// (a, b = k+1, k+2), then V -> clip: dx = W/2 gV.x, dy = -H/2 gV.y,
// dw = W/2 gV.x + H/2 gV.y + gV.w.
void clip_weights_backward(const TriangleWeights& tw, const detail::HVec& e, int width, int height, const double* G,
                           double* xyw) {
  detail::HVec gV[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  auto add = [](detail::HVec& acc, const detail::HVec& d, double g) {
    acc.x += g * d.x;
    acc.y += g * d.y;
    acc.w += g * d.w;
  };
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const double gF = G[k] * tw.inv_d;
    add(gV[a], detail::cross(tw.V[b], e), gF);
    add(gV[b], detail::cross(e, tw.V[a]), gF);
  }
  const double hw = 0.5 * width, hh = 0.5 * height;
  for (int k = 0; k < 3; ++k) {
    xyw[3 * k] = hw * gV[k].x;
    xyw[3 * k + 1] = -hh * gV[k].y;
    xyw[3 * k + 2] = hw * gV[k].x + hh * gV[k].y + gV[k].w;
  }
}

// Items the forward and the adjoint take at once in their vectorized loops.
// Their lane arrays are written element by element and read a vector at a
// time; with 8 lanes the reads came soon enough after the writes to stall on
// store forwarding (perf: 17% of the forward loop on one load), with 16 they
// do not (bench_ops interpolate, 1 thread: forward 5.8 ms with 8 lanes, 4.6 to
// 5.0 ms with 16 or 32).
constexpr int kLanes = 16;

// interpolate_forward over items [lo, hi) in the common case, vectorized across
// items: perspective weights from 1 / w_k (no vertex behind the near plane)
// and kC channels. Each batch's w_k, attribute rows and uv are gathered into
// per-lane arrays, the weights and values computed lane by lane with
// triangle_weights' and pixel_weights' arithmetic in the same order (so the
// same bits), then written, background items as in the item loop.
template <int kC, class T>
void interpolate_front_items(const InterpolateParams<T>& prm, std::int64_t lo, std::int64_t hi, T* out) {
  for (std::int64_t p0 = lo; p0 < hi; p0 += kLanes) {
    const int n = static_cast<int>(std::min<std::int64_t>(kLanes, hi - p0));
    bool any_covered = false;
    for (int i = 0; i < n; ++i) any_covered |= prm.tri_id[p0 + i] != 0;
    if (!any_covered) {  // all background (most of an image's corners)
      for (int i = 0; i < n; ++i)
        for (int c = 0; c < kC; ++c) out[(p0 + i) * kC + c] = prm.background ? prm.background[c] : T(0);
      continue;
    }
    // Gather (background lanes and lanes past n get w = 1 and zeros, unused).
    double u[kLanes], v[kLanes], w[3][kLanes], a[3][kC][kLanes];
    for (int i = 0; i < kLanes; ++i) {
      const std::int32_t id = i < n ? prm.tri_id[p0 + i] : 0;
      const std::int32_t* tri = id ? prm.tris + 3 * static_cast<std::int64_t>(id - 1) : nullptr;
      u[i] = tri ? static_cast<double>(prm.uv[2 * (p0 + i)]) : 0.0;
      v[i] = tri ? static_cast<double>(prm.uv[2 * (p0 + i) + 1]) : 0.0;
      for (int k = 0; k < 3; ++k) {
        w[k][i] = tri ? static_cast<double>(prm.clip[4 * static_cast<std::int64_t>(tri[k]) + 3]) : 1.0;
        for (int c = 0; c < kC; ++c) a[k][c][i] = tri ? static_cast<double>(prm.attr[tri[k] * kC + c]) : 0.0;
      }
    }
    // q_k = lambda_k / w_k, weight_k = q_k / sum q, A = sum_k weight_k A_k.
    double value[kC][kLanes];
    for (int i = 0; i < kLanes; ++i) {
      const double q[3] = {(1.0 - u[i] - v[i]) * detail::safe_inv(w[0][i]), u[i] * detail::safe_inv(w[1][i]),
                           v[i] * detail::safe_inv(w[2][i])};
      double weight[3];
      weights_from(q, weight);
      for (int c = 0; c < kC; ++c)
        value[c][i] = weight[0] * a[0][c][i] + weight[1] * a[1][c][i] + weight[2] * a[2][c][i];
    }
    for (int i = 0; i < n; ++i) {
      T* o = out + (p0 + i) * kC;
      if (prm.tri_id[p0 + i] == 0)
        for (int c = 0; c < kC; ++c) o[c] = prm.background ? prm.background[c] : T(0);
      else
        for (int c = 0; c < kC; ++c) o[c] = static_cast<T>(value[c][i]);
    }
  }
}

}  // namespace

// The image and fragment forms run the same loops: "items" are the pixels of
// an image (tri_id 0 = background) or the covered pixels of a fragment list
// (tri_id never 0); item p reads tri_id[p], uv[2p, 2p+1] and writes or reads
// C values at p * C; `items` gives its pixel (for clipped triangles' weights).
template <class T>
void interpolate_forward(const InterpolateParams<T>& prm, T* out) {
  assert(prm.width >= 1 && prm.height >= 1 && prm.channels >= 0 && prm.count >= 0);
  const T *attr = prm.attr, *clip = prm.clip, *uv = prm.uv, *background = prm.background;
  const std::int32_t *tris = prm.tris, *tri_id = prm.tri_id;
  const std::int64_t C = prm.channels, P = prm.items();
  const bool perspective = prm.perspective;
  const Items items = make_items(prm);
  const bool front = perspective && !items.any_behind;
  parallel_for(0, P, 4096, [&](std::int64_t lo, std::int64_t hi) {
    if (front && C >= 1 && C <= 4) {  // the usual channel counts, vectorized
      switch (C) {
        case 1: interpolate_front_items<1>(prm, lo, hi, out); return;
        case 2: interpolate_front_items<2>(prm, lo, hi, out); return;
        case 3: interpolate_front_items<3>(prm, lo, hi, out); return;
        default: interpolate_front_items<4>(prm, lo, hi, out); return;
      }
    }
    for (std::int64_t p = lo; p < hi; ++p) {
      T* o = out + p * C;
      // Background: the given colour, or zeros.
      if (tri_id[p] == 0) {
        for (std::int64_t c = 0; c < C; ++c) o[c] = background ? background[c] : T(0);
        continue;
      }
      const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
      const PixelWeights pw = pixel_weights(clip, tri, uv, perspective, items, p);
      // A = sum_k weight_k A_k.
      const T* a0 = attr + tri[0] * C;
      const T* a1 = attr + tri[1] * C;
      const T* a2 = attr + tri[2] * C;
      for (std::int64_t c = 0; c < C; ++c)
        o[c] = static_cast<T>(pw.weight[0] * a0[c] + pw.weight[1] * a1[c] + pw.weight[2] * a2[c]);
    }
  });
}

namespace {

// What one covered item with a non-zero incoming gradient sends to its
// triangle's corners: dL/dA_k = weight_k g, and dL/dw_k (grad_w) or, for a
// clipped triangle, dL/d(x, y, w)_k (xyw).
struct ItemTerms {
  double weight[3], grad_w[3], xyw[9];
  bool clipped;
};

// The triangle of the items being summed: its weights' per-triangle part and
// the attribute rows of its vertices.
template <class T>
struct TriangleTerms {
  TriangleWeights weights;
  const T* a[3];
};

template <class T>
TriangleTerms<T> triangle_terms(const InterpolateParams<T>& prm, const Items& items, std::int64_t t) {
  const std::int32_t* tri = prm.tris + 3 * t;
  const std::int64_t C = prm.channels;
  return {triangle_weights(prm.clip, tri, prm.perspective, items),
          {prm.attr + tri[0] * C, prm.attr + tri[1] * C, prm.attr + tri[2] * C}};
}

// Per-item terms of the adjoint (formulas in interpolate.h) for item p on
// triangle tt; adds dL/du, dL/dv to grad_uv (its own entries only). False
// when the incoming gradient is zero. value: scratch of C doubles. kC: the
// channel count when the caller fixed it at compile time (0: prm.channels),
// so the short channel loops unroll; the arithmetic is the same either way.
template <int kC, class T>
inline bool item_terms(const InterpolateParams<T>& prm, const Items& items, const TriangleTerms<T>& tt,
                       const T* grad_out, T* grad_uv, bool want_xyw, std::int64_t p, double* value, ItemTerms* out) {
  const std::int64_t C = kC > 0 ? kC : prm.channels;
  const T* g = grad_out + p * C;
  // Zero incoming gradient: skip.
  bool any = false;
  for (std::int64_t c = 0; c < C && !any; ++c) any = g[c] != T(0);
  if (!any) return false;
  const TriangleWeights& tw = tt.weights;
  const PixelWeights pw = pixel_weights(tw, prm.uv, items, p);
  const T* const* a = tt.a;
  double g_lambda[3];
  out->clipped = false;
  if (!prm.perspective) {
    // dL/dlambda_k = g . A_k.
    for (int k = 0; k < 3; ++k) {
      double d = 0.0;
      for (std::int64_t c = 0; c < C; ++c) d += static_cast<double>(g[c]) * a[k][c];
      g_lambda[k] = d;
      out->grad_w[k] = 0.0;
    }
  } else {
    // A at this pixel, then G_k = dL/dq_k = g . (A_k - A) / s.
    for (std::int64_t c = 0; c < C; ++c)
      value[c] = pw.weight[0] * a[0][c] + pw.weight[1] * a[1][c] + pw.weight[2] * a[2][c];
    double G[3];
    for (int k = 0; k < 3; ++k) {
      double d = 0.0;
      for (std::int64_t c = 0; c < C; ++c) d += static_cast<double>(g[c]) * (a[k][c] - value[c]);
      G[k] = d * pw.inv_s;
    }
    if (tw.from_clip) {
      // q_k = F_k / D does not depend on u, v.
      for (int k = 0; k < 3; ++k) g_lambda[k] = 0.0;
      if (want_xyw) clip_weights_backward(tw, pw.e, items.width, items.height, G, out->xyw);
      out->clipped = true;
    } else {
      // q_k = lambda_k / w_k: dL/dlambda_k = G_k / w_k ; dL/dw_k = -G_k q_k / w_k.
      for (int k = 0; k < 3; ++k) {
        g_lambda[k] = G[k] * tw.inv_w[k];
        out->grad_w[k] = -G[k] * pw.q[k] * tw.inv_w[k];
      }
    }
  }
  for (int k = 0; k < 3; ++k) out->weight[k] = pw.weight[k];
  // u = lambda_1, v = lambda_2, lambda_0 = 1 - u - v.
  if (grad_uv) {
    grad_uv[2 * p] += static_cast<T>(g_lambda[1] - g_lambda[0]);
    grad_uv[2 * p + 1] += static_cast<T>(g_lambda[2] - g_lambda[0]);
  }
  return true;
}

// The adjoint's buffers, reused across calls.
struct BackwardScratch {
  detail::Buckets by_tri, by_vertex;
  std::vector<double> partial;
  std::vector<std::uint8_t> live;
};
detail::ScratchPool<BackwardScratch> g_backward_pool;

// Step 2 of the adjoint (below): what it reads and where it sums.
template <class T>
struct CornerSums {
  const detail::Buckets& by_tri;
  const Items& items;
  const T* grad_out;
  T* grad_uv;
  bool want_xyw;
  std::int64_t SA, SC;  // per corner: SA attribute sums, then SC clip sums (0, 1: w, 3: x, y, w)
  BackwardScratch* sc;
};

// sum_corners' walk over one triangle in the common case, vectorized across
// items: perspective weights from 1 / w_k (the triangle is in front of the near
// plane) and kC > 0 channels. Each batch of items is gathered into per-lane
// arrays, its terms computed lane by lane with item_terms' arithmetic in the
// same order (so the same bits), then added to the corner sums in item order.
// Writes corner k's sums to acc[k S, k S + kC) (when with_attr) and its dL/dw_k
// to acc[k S + w_slot] (when w_slot >= 0). Returns whether any item had a
// non-zero incoming gradient (item_terms' skip rule).
template <int kC, class T>
bool sum_front_items(const InterpolateParams<T>& prm, const TriangleTerms<T>& tt, const std::int32_t* item,
                     std::int64_t count, const T* grad_out, T* grad_uv, bool with_attr, std::int64_t w_slot,
                     std::int64_t S, double* acc) {
  const double* inv_w = tt.weights.inv_w;
  double A[3][kC];
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < kC; ++c) A[k][c] = static_cast<double>(tt.a[k][c]);
  // Corner k's sums: kC attribute sums, then dL/dw_k.
  constexpr int kSums = 3 * (kC + 1);
  double sums[kSums] = {};
  bool live = false;
  for (std::int64_t e0 = 0; e0 < count; e0 += kLanes) {
    const int n = static_cast<int>(std::min<std::int64_t>(kLanes, count - e0));
    // Gather (lanes past n are zeros, computed and never used); fetch the
    // next batch's rows early, as the walk jumps between pixel rows.
    double u[kLanes], v[kLanes], g[kC][kLanes];
    for (int i = 0; i < kLanes; ++i) {
      if (e0 + kLanes + i < count) {
        const std::int64_t pa = item[e0 + kLanes + i];
        __builtin_prefetch(grad_out + pa * kC);
        __builtin_prefetch(prm.uv + 2 * pa);
        if (grad_uv) __builtin_prefetch(grad_uv + 2 * pa);
      }
      const std::int64_t p = i < n ? item[e0 + i] : -1;
      u[i] = p >= 0 ? static_cast<double>(prm.uv[2 * p]) : 0.0;
      v[i] = p >= 0 ? static_cast<double>(prm.uv[2 * p + 1]) : 0.0;
      for (int c = 0; c < kC; ++c) g[c][i] = p >= 0 ? static_cast<double>(grad_out[p * kC + c]) : 0.0;
    }
    // pixel_weights and item_terms, lane by lane.
    double terms[kSums][kLanes], du[kLanes], dv[kLanes];
    for (int i = 0; i < kLanes; ++i) {
      const double q[3] = {(1.0 - u[i] - v[i]) * inv_w[0], u[i] * inv_w[1], v[i] * inv_w[2]};
      double w[3];
      const double inv_s = weights_from(q, w);
      double value[kC];
      for (int c = 0; c < kC; ++c) value[c] = w[0] * A[0][c] + w[1] * A[1][c] + w[2] * A[2][c];
      double g_lambda[3];
      for (int k = 0; k < 3; ++k) {
        double d = 0.0;
        for (int c = 0; c < kC; ++c) d += g[c][i] * (A[k][c] - value[c]);
        const double G = d * inv_s;
        g_lambda[k] = G * inv_w[k];
        // dL/dA_k += weight_k g; dL/dw_k.
        for (int c = 0; c < kC; ++c) terms[k * (kC + 1) + c][i] = w[k] * g[c][i];
        terms[k * (kC + 1) + kC][i] = -G * q[k] * inv_w[k];
      }
      du[i] = g_lambda[1] - g_lambda[0];
      dv[i] = g_lambda[2] - g_lambda[0];
    }
    // In item order: dL/duv, then the corner sums.
    for (int i = 0; i < n; ++i) {
      bool any = false;
      for (int c = 0; c < kC; ++c) any |= g[c][i] != 0.0;
      if (!any) continue;
      live = true;
      if (grad_uv) {
        const std::int64_t p = item[e0 + i];
        grad_uv[2 * p] += static_cast<T>(du[i]);
        grad_uv[2 * p + 1] += static_cast<T>(dv[i]);
      }
      for (int j = 0; j < kSums; ++j) sums[j] += terms[j][i];
    }
  }
  for (int k = 0; k < 3; ++k) {
    if (with_attr)
      for (int c = 0; c < kC; ++c) acc[k * S + c] = sums[k * (kC + 1) + c];
    if (w_slot >= 0) acc[k * S + w_slot] = sums[k * (kC + 1) + kC];
  }
  return live;
}

// Per used triangle, in parallel (in first-item order: a sweep down the image),
// each item's terms summed per corner in item order. Corner k of used triangle
// s holds S = SA + SC doubles at (3 s + k) S: dL/dA_k (SA = C values, or 0),
// then dL/dw_k (SC = 1) or dL/d(x, y, w)_k (SC = 3: a vertex behind the near
// plane). kC as in item_terms.
template <int kC, class T>
void sum_corners(const InterpolateParams<T>& prm, const CornerSums<T>& cs) {
  const detail::Buckets& by_tri = cs.by_tri;
  const std::int64_t used = static_cast<std::int64_t>(by_tri.nonempty.size());
  const std::int64_t C = kC > 0 ? kC : prm.channels;
  const std::int64_t SA = cs.SA, SC = cs.SC, S = SA + SC;
  const T* grad_out = cs.grad_out;
  T* grad_uv = cs.grad_uv;
  double* partial = cs.sc->partial.data();
  std::uint8_t* live_of = cs.sc->live.data();
  constexpr std::int64_t kAhead = 4;
  parallel_for(0, used, 16, [&](std::int64_t s0, std::int64_t s1) {
    std::vector<double> value(static_cast<std::size_t>(C));
    ItemTerms t;
    for (std::int64_t s = s0; s < s1; ++s) {
      double* acc = partial + 3 * s * S;
      std::fill(acc, acc + 3 * S, 0.0);
      std::uint8_t live = 0;
      const std::int32_t tri = by_tri.nonempty[s];
      const TriangleTerms<T> tt = triangle_terms(prm, cs.items, tri);
      const std::int64_t e1 = by_tri.start[tri + 1];
      if constexpr (kC > 0) {
        if (prm.perspective && !tt.weights.from_clip) {
          const std::int64_t e0 = by_tri.start[tri];
          live_of[s] = sum_front_items<kC>(prm, tt, by_tri.item.data() + e0, e1 - e0, grad_out, grad_uv, SA > 0,
                                           SC == 0 ? -1 : SA + (SC == 3 ? 2 : 0), S, acc);
          continue;
        }
      }
      for (std::int64_t e = by_tri.start[tri]; e < e1; ++e) {
        const std::int64_t p = by_tri.item[e];
        // The walk jumps between pixel rows: fetch a later item's data early.
        if (e + kAhead < e1) {
          const std::int64_t pa = by_tri.item[e + kAhead];
          __builtin_prefetch(grad_out + pa * C);
          __builtin_prefetch(prm.uv + 2 * pa);
          if (grad_uv) __builtin_prefetch(grad_uv + 2 * pa);
        }
        if (!item_terms<kC>(prm, cs.items, tt, grad_out, grad_uv, cs.want_xyw, p, value.data(), &t)) continue;
        live = 1;
        const T* g = grad_out + p * C;
        for (int k = 0; k < 3; ++k) {
          double* o = acc + k * S;
          // dL/dA_k += weight_k g.
          if (SA)
            for (std::int64_t c = 0; c < C; ++c) o[c] += t.weight[k] * static_cast<double>(g[c]);
          if (SC == 1) {
            o[SA] += t.grad_w[k];
          } else if (SC == 3) {
            if (t.clipped) {
              o[SA] += t.xyw[3 * k];
              o[SA + 1] += t.xyw[3 * k + 1];
              o[SA + 2] += t.xyw[3 * k + 2];
            } else {
              o[SA + 2] += t.grad_w[k];
            }
          }
        }
      }
      live_of[s] = live;
    }
  });
}

}  // namespace

template <class T>
void interpolate_backward(const InterpolateParams<T>& prm, const T* grad_out, const InterpolateGrads<T>& grads) {
  assert(prm.width >= 1 && prm.height >= 1 && prm.channels >= 0 && prm.count >= 0);
  T* const grad_attr = grads.attr;
  // Only the perspective mode has a gradient to clip.
  T* const grad_clip = prm.perspective ? grads.clip : nullptr;
  T* const grad_uv = grads.uv;
  const std::int64_t C = prm.channels, P = prm.items();
  if (!grad_attr && !grad_clip && !grad_uv) return;
  const Items items = make_items(prm);
  const bool want_xyw = grad_clip && items.any_behind;

  // Only dL/duv: per-item terms in parallel, nothing to sum.
  if (!grad_attr && !grad_clip) {
    parallel_for(0, P, 1024, [&](std::int64_t lo, std::int64_t hi) {
      std::vector<double> value(static_cast<std::size_t>(C));
      ItemTerms t;
      for (std::int64_t p = lo; p < hi; ++p)
        if (prm.tri_id[p] != 0)
          item_terms<0>(prm, items, triangle_terms(prm, items, prm.tri_id[p] - 1), grad_out, grad_uv, false, p,
                        value.data(), &t);
    });
    return;
  }

  // Scatter by gathering (docs/determinism.md): 1. covered items grouped by
  // triangle, each triangle's items in ascending item order; the used
  // triangles numbered s = 0, 1, ... by first item.
  auto lease = g_backward_pool.take();
  BackwardScratch& sc = *lease;
  const std::int32_t* tri_id = prm.tri_id;
  const detail::Buckets* shared = prm.groups ? prm.groups->by_triangle(tri_id, P, prm.num_tris) : nullptr;
  if (!shared)
    detail::bucket_items(P, prm.num_tris, [&](std::int64_t p) -> std::int64_t { return tri_id[p] - 1; }, &sc.by_tri);
  const detail::Buckets& by_tri = shared ? *shared : sc.by_tri;
  const std::int64_t used = static_cast<std::int64_t>(by_tri.nonempty.size());

  // 2. Per triangle, each item's terms summed per corner in item order
  // (sum_corners).
  const std::int64_t SA = grad_attr ? C : 0;
  const std::int64_t SC = grad_clip ? (want_xyw ? 3 : 1) : 0;
  const std::int64_t S = SA + SC;
  sc.partial.resize(static_cast<std::size_t>(3 * used * S));
  sc.live.resize(static_cast<std::size_t>(used));
  const CornerSums<T> sums{by_tri, items, grad_out, grad_uv, want_xyw, SA, SC, &sc};
  switch (C) {  // the usual channel counts get unrolled channel loops
    case 1: sum_corners<1>(prm, sums); break;
    case 2: sum_corners<2>(prm, sums); break;
    case 3: sum_corners<3>(prm, sums); break;
    case 4: sum_corners<4>(prm, sums); break;
    default: sum_corners<0>(prm, sums); break;
  }

  // 3. Each vertex adds its corners' sums in corner order, once.
  detail::gather_corners(prm.tris, by_tri.nonempty.data(), used, sc.live.data(), sc.partial.data(), S,
                         prm.num_vertices, &sc.by_vertex, [&](std::int64_t v, const double* total) {
                           if (grad_attr)
                             for (std::int64_t c = 0; c < C; ++c) grad_attr[v * C + c] += static_cast<T>(total[c]);
                           T* gc = grad_clip ? grad_clip + 4 * v : nullptr;
                           if (SC == 1) {
                             gc[3] += static_cast<T>(total[SA]);
                           } else if (SC == 3) {
                             gc[0] += static_cast<T>(total[SA]);
                             gc[1] += static_cast<T>(total[SA + 1]);
                             gc[3] += static_cast<T>(total[SA + 2]);
                           }
                         });
}

template <class T>
void interpolate_derivatives(const InterpolateParams<T>& prm, T* d_dx, T* d_dy) {
  assert(!prm.pixel_index && prm.width >= 1 && prm.height >= 1);
  const T *attr = prm.attr, *clip = prm.clip, *uv = prm.uv;
  const std::int32_t *tris = prm.tris, *tri_id = prm.tri_id;
  const std::int64_t C = prm.channels, P = prm.items();
  const int width = prm.width, height = prm.height;
  const bool perspective = prm.perspective;
  const Items items = make_items(prm);
  parallel_for(0, P, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t p = lo; p < hi; ++p) {
      T* ox = d_dx + p * C;
      T* oy = d_dy + p * C;
      if (tri_id[p] == 0) {
        for (std::int64_t c = 0; c < C; ++c) ox[c] = oy[c] = T(0);
        continue;
      }
      const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
      // Homogeneous screen vertices, c_k = V_{k+1} x V_{k+2}, D = V_0 . c_0.
      detail::HVec V[3];
      homogeneous_vertices(clip, tri, width, height, V);
      detail::HVec cr[3];
      for (int k = 0; k < 3; ++k) cr[k] = detail::cross(V[(k + 1) % 3], V[(k + 2) % 3]);
      const double inv_d = safe_inv(detail::dot(V[0], cr[0]));
      // dlambda_k/dx = w_k c_k.x / D, dlambda_k/dy = w_k c_k.y / D.
      double dlx[3], dly[3];
      for (int k = 0; k < 3; ++k) {
        dlx[k] = V[k].w * cr[k].x * inv_d;
        dly[k] = V[k].w * cr[k].y * inv_d;
      }
      const PixelWeights pw = pixel_weights(clip, tri, uv, perspective, items, p);
      const T* a[3] = {attr + tri[0] * C, attr + tri[1] * C, attr + tri[2] * C};
      if (!perspective) {
        // dA/dx = sum_k dlambda_k/dx A_k.
        for (std::int64_t c = 0; c < C; ++c) {
          ox[c] = static_cast<T>(dlx[0] * a[0][c] + dlx[1] * a[1][c] + dlx[2] * a[2][c]);
          oy[c] = static_cast<T>(dly[0] * a[0][c] + dly[1] * a[1][c] + dly[2] * a[2][c]);
        }
        continue;
      }
      // q_k = lambda_k / w_k = (e . c_k) / D: dq_k/dx = c_k.x / D, not divided by
      // w_k (exact at w_k = 0); dA/dx = sum_k dq_k/dx (A_k - A) / s.
      double dqx[3], dqy[3];
      for (int k = 0; k < 3; ++k) {
        dqx[k] = cr[k].x * inv_d * pw.inv_s;
        dqy[k] = cr[k].y * inv_d * pw.inv_s;
      }
      for (std::int64_t c = 0; c < C; ++c) {
        const double A = pw.weight[0] * a[0][c] + pw.weight[1] * a[1][c] + pw.weight[2] * a[2][c];
        double sx = 0.0, sy = 0.0;
        for (int k = 0; k < 3; ++k) {
          sx += dqx[k] * (a[k][c] - A);
          sy += dqy[k] * (a[k][c] - A);
        }
        ox[c] = static_cast<T>(sx);
        oy[c] = static_cast<T>(sy);
      }
    }
  });
}

#define GR_INSTANTIATE(T)                                                                   \
  template void interpolate_forward<T>(const InterpolateParams<T>&, T*);                    \
  template void interpolate_backward<T>(const InterpolateParams<T>&, const T*, const InterpolateGrads<T>&); \
  template void interpolate_derivatives<T>(const InterpolateParams<T>&, T*, T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
