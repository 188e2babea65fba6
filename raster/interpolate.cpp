// Attribute interpolation forward and adjoint. Both loop over pixels (image
// form) or fragments (fragment form: the covered pixels only, in ascending
// pixel order) in parallel, through the same per-item loops; the adjoint's
// per-vertex sums are scattered in item order in fixed chunks so gradients do
// not depend on thread count or triangle order, and the two forms give
// bit-identical results.
#include "raster/interpolate.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "autodiff/parallel.h"
#include "raster/guarded_math.h"
#include "raster/rasterize_setup.h"

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
// returns 1/w_k, q_k and 1/s for the adjoint. Clipped triangles take q_k from
// the clip positions and the pixel centre e instead: q_k = F_k / D with
// F_k = e . (V_k+1 x V_k+2), D = V_0 . (V_1 x V_2) (docs/rasterizer.md). That is
// the same value (rasterize stores lambda_k = w_k F_k / D), but it stays exact
// at w_k = 0, where lambda_k = 0 and lambda_k / w_k loses the vertex's weight.
struct PixelWeights {
  double lambda[3], weight[3], inv_w[3], q[3], inv_s;
  bool from_clip = false;  // q_k = F_k / D; then V, e and inv_d are set
  detail::HVec V[3], e;
  double inv_d;
};

template <class T>
PixelWeights pixel_weights(const T* clip, const std::int32_t* tri, const T* uv, bool perspective,
                           const Items& items, std::int64_t p) {
  PixelWeights pw;
  const double u = uv[2 * p], v = uv[2 * p + 1];
  pw.lambda[0] = 1.0 - u - v;
  pw.lambda[1] = u;
  pw.lambda[2] = v;
  if (!perspective) {
    for (int k = 0; k < 3; ++k) pw.weight[k] = pw.lambda[k];
    return pw;
  }
  double s = 0.0;
  if (items.any_behind && is_clipped(clip, tri)) {
    // q_k = F_k / D.
    pw.from_clip = true;
    homogeneous_vertices(clip, tri, items.width, items.height, pw.V);
    pw.e = items.centre(p);
    pw.inv_d = safe_inv(detail::dot(pw.V[0], detail::cross(pw.V[1], pw.V[2])));
    for (int k = 0; k < 3; ++k) {
      pw.q[k] = detail::dot(pw.e, detail::cross(pw.V[(k + 1) % 3], pw.V[(k + 2) % 3])) * pw.inv_d;
      s += pw.q[k];
    }
  } else {
    // q_k = lambda_k / w_k.
    for (int k = 0; k < 3; ++k) {
      pw.inv_w[k] = safe_inv(static_cast<double>(clip[4 * static_cast<std::int64_t>(tri[k]) + 3]));
      pw.q[k] = pw.lambda[k] * pw.inv_w[k];
      s += pw.q[k];
    }
  }
  pw.inv_s = safe_inv(s);
  for (int k = 0; k < 3; ++k) pw.weight[k] = pw.q[k] * pw.inv_s;
  return pw;
}

// Adjoint of q_k = F_k / D (clipped triangles) for dL/dq_k = G_k, written as
// dL/d(x, y, w) of the three vertices to xyw[3k..3k+2]. dL/dD = -sum_k G_k q_k / D
// is 0 (G_k = g . (A_k - A) / s and sum_k q_k (A_k - A) = 0), so only
// dL/dF_k = G_k / D is propagated: dF_k/dV_a = V_b x e, dF_k/dV_b = e x V_a
// (a, b = k+1, k+2), then V -> clip: dx = W/2 gV.x, dy = -H/2 gV.y,
// dw = W/2 gV.x + H/2 gV.y + gV.w.
void clip_weights_backward(const PixelWeights& pw, int width, int height, const double* G, double* xyw) {
  detail::HVec gV[3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  auto add = [](detail::HVec& acc, const detail::HVec& d, double g) {
    acc.x += g * d.x;
    acc.y += g * d.y;
    acc.w += g * d.w;
  };
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const double gF = G[k] * pw.inv_d;
    add(gV[a], detail::cross(pw.V[b], pw.e), gF);
    add(gV[b], detail::cross(pw.e, pw.V[a]), gF);
  }
  const double hw = 0.5 * width, hh = 0.5 * height;
  for (int k = 0; k < 3; ++k) {
    xyw[3 * k] = hw * gV[k].x;
    xyw[3 * k + 1] = -hh * gV[k].y;
    xyw[3 * k + 2] = hw * gV[k].x + hh * gV[k].y + gV[k].w;
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
  parallel_for(0, P, 4096, [&](std::int64_t lo, std::int64_t hi) {
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
// The adjoint's per-chunk buffers, reused across calls.
struct BackwardScratch {
  std::vector<double> weight, grad_w, grad_xyw;
  std::vector<std::uint8_t> live;
};
detail::ScratchPool<BackwardScratch> g_backward_pool;
}  // namespace

template <class T>
void interpolate_backward(const InterpolateParams<T>& prm, const T* grad_out, const InterpolateGrads<T>& grads) {
  assert(prm.width >= 1 && prm.height >= 1 && prm.channels >= 0 && prm.count >= 0);
  T* const grad_attr = grads.attr;
  T* grad_clip = grads.clip;
  T* const grad_uv = grads.uv;
  const T *attr = prm.attr, *clip = prm.clip, *uv = prm.uv;
  const std::int32_t *tris = prm.tris, *tri_id = prm.tri_id;
  const std::int64_t N = prm.num_vertices, C = prm.channels, P = prm.items();
  const bool perspective = prm.perspective;
  if (!grad_attr && !grad_clip && !grad_uv) return;
  // Only the perspective mode has a gradient to clip.
  if (!perspective) grad_clip = nullptr;
  const bool scatter = grad_attr || grad_clip;
  // One vertex range per thread for the scatter (any count gives the same bits).
  const std::int64_t vertex_groups = std::max<std::int64_t>(1, std::min<std::int64_t>(num_threads(), N));
  const std::int64_t per_group = (N + vertex_groups - 1) / vertex_groups;
  const Items items = make_items(prm);

  // Items in chunks: per-item terms in parallel, per-vertex sums in item order.
  // live: 0 skip, 1 gradient to w (grad_w), 2 to x, y, w (grad_xyw; clipped triangle).
  enum : std::uint8_t { kSkip = 0, kToW = 1, kToXYW = 2 };
  // Scratch for one chunk, sized to the chunk actually used (small images
  // allocate and zero only what they need; the chunk boundaries are unchanged).
  constexpr std::int64_t kChunk = 32768;
  const auto len = static_cast<std::size_t>(std::min(kChunk, P));
  // Pooled, so an optimization loop does not fault in fresh pages every call.
  auto lease = g_backward_pool.take();
  std::vector<double>& weight = lease->weight;
  std::vector<double>& grad_w = lease->grad_w;
  std::vector<double>& grad_xyw = lease->grad_xyw;
  std::vector<std::uint8_t>& live = lease->live;
  weight.resize(3 * len);
  grad_w.resize(3 * len);
  if (grad_clip && items.any_behind) grad_xyw.resize(9 * len);
  live.resize(len);
  for (std::int64_t c0 = 0; c0 < P; c0 += kChunk) {
    const std::int64_t c1 = std::min(P, c0 + kChunk);
    parallel_for(c0, c1, 1024, [&](std::int64_t lo, std::int64_t hi) {
      std::vector<double> value(static_cast<std::size_t>(C));
      for (std::int64_t p = lo; p < hi; ++p) {
        const std::int64_t i = p - c0;
        live[i] = kSkip;
        if (tri_id[p] == 0) continue;
        const T* g = grad_out + p * C;
        // Zero incoming gradient: skip.
        bool any = false;
        for (std::int64_t c = 0; c < C && !any; ++c) any = g[c] != T(0);
        if (!any) continue;
        live[i] = kToW;
        const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
        const PixelWeights pw = pixel_weights(clip, tri, uv, perspective, items, p);
        const T* a[3] = {attr + tri[0] * C, attr + tri[1] * C, attr + tri[2] * C};
        double g_lambda[3];
        if (!perspective) {
          // dL/dlambda_k = g . A_k.
          for (int k = 0; k < 3; ++k) {
            double d = 0.0;
            for (std::int64_t c = 0; c < C; ++c) d += static_cast<double>(g[c]) * a[k][c];
            g_lambda[k] = d;
            grad_w[3 * i + k] = 0.0;
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
          if (pw.from_clip) {
            // q_k = F_k / D does not depend on u, v.
            for (int k = 0; k < 3; ++k) g_lambda[k] = 0.0;
            if (grad_clip) clip_weights_backward(pw, items.width, items.height, G, &grad_xyw[9 * i]);
            live[i] = kToXYW;
          } else {
            // q_k = lambda_k / w_k: dL/dlambda_k = G_k / w_k ; dL/dw_k = -G_k q_k / w_k.
            for (int k = 0; k < 3; ++k) {
              g_lambda[k] = G[k] * pw.inv_w[k];
              grad_w[3 * i + k] = -G[k] * pw.q[k] * pw.inv_w[k];
            }
          }
        }
        for (int k = 0; k < 3; ++k) weight[3 * i + k] = pw.weight[k];
        // u = lambda_1, v = lambda_2, lambda_0 = 1 - u - v.
        if (grad_uv) {
          grad_uv[2 * p] += static_cast<T>(g_lambda[1] - g_lambda[0]);
          grad_uv[2 * p + 1] += static_cast<T>(g_lambda[2] - g_lambda[0]);
        }
      }
    });
    if (!scatter) continue;
    // Scatter in item order: dL/dA_k += weight_k g, dL/dw_k += grad_w_k (or
    // dL/d(x, y, w)_k += grad_xyw_k). Each thread owns a range of vertices and
    // walks all items in order, so every vertex sums its contributions in item
    // order: the result does not depend on how many ranges there are.
    parallel_for(0, vertex_groups, 1, [&](std::int64_t g0, std::int64_t g1) {
      const std::int64_t v0 = g0 * per_group, v1 = std::min(N, g1 * per_group);
      for (std::int64_t p = c0; p < c1; ++p) {
        const std::int64_t i = p - c0;
        if (live[i] == kSkip) continue;
        const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
        const T* g = grad_out + p * C;
        for (int k = 0; k < 3; ++k) {
          if (tri[k] < v0 || tri[k] >= v1) continue;
          if (grad_attr) {
            T* ga = grad_attr + tri[k] * C;
            const double wk = weight[3 * i + k];
            for (std::int64_t c = 0; c < C; ++c) ga[c] += static_cast<T>(wk * g[c]);
          }
          if (!grad_clip) continue;
          T* gc = grad_clip + 4 * static_cast<std::int64_t>(tri[k]);
          if (live[i] == kToXYW) {
            const double* gk = &grad_xyw[9 * i + 3 * k];
            gc[0] += static_cast<T>(gk[0]);
            gc[1] += static_cast<T>(gk[1]);
            gc[3] += static_cast<T>(gk[2]);
          } else {
            gc[3] += static_cast<T>(grad_w[3 * i + k]);
          }
        }
      }
    });
  }
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
