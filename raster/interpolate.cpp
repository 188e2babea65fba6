// Attribute interpolation forward and adjoint. Both loop over pixels in
// parallel; the adjoint's per-vertex sums are scattered in pixel order in
// fixed chunks so gradients do not depend on thread count or triangle order.
#include "raster/interpolate.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "autodiff/error.h"
#include "autodiff/parallel.h"
#include "raster/guarded_math.h"
#include "raster/rasterize_setup.h"

namespace gr::raster {
namespace {

using detail::safe_inv;

// 1 / x, kept finite for |x| -> 0 (sign preserved; x = 0 counts as positive).
// Weights of the three vertices at one pixel: A = sum_k weight_k A_k.
// Also returns 1/w_k, lambda_k / w_k and 1/s for the adjoint (perspective only).
struct PixelWeights {
  double lambda[3], weight[3], inv_w[3], q[3], inv_s;
};

template <class T>
PixelWeights pixel_weights(const T* clip, const std::int32_t* tri, const T* uv_p, bool perspective) {
  PixelWeights pw;
  const double u = uv_p[0], v = uv_p[1];
  pw.lambda[0] = 1.0 - u - v;
  pw.lambda[1] = u;
  pw.lambda[2] = v;
  if (!perspective) {
    for (int k = 0; k < 3; ++k) pw.weight[k] = pw.lambda[k];
    return pw;
  }
  // q_k = lambda_k / w_k, s = sum q_k, weight_k = q_k / s.
  double s = 0.0;
  for (int k = 0; k < 3; ++k) {
    pw.inv_w[k] = safe_inv(static_cast<double>(clip[4 * static_cast<std::int64_t>(tri[k]) + 3]));
    pw.q[k] = pw.lambda[k] * pw.inv_w[k];
    s += pw.q[k];
  }
  pw.inv_s = safe_inv(s);
  for (int k = 0; k < 3; ++k) pw.weight[k] = pw.q[k] * pw.inv_s;
  return pw;
}

void check_args(std::int64_t num_vertices, std::int64_t channels, const std::int32_t* tris,
                std::int64_t num_tris, const std::int32_t* tri_id, int width, int height,
                const char* op) {
  detail::check_image_size(width, height, op);
  if (channels < 0) throw ShapeError(std::string(op) + ": attribute channel count is negative");
  detail::check_triangles(tris, num_tris, num_vertices, op);
  detail::check_tri_ids(tri_id, static_cast<std::int64_t>(width) * height, num_tris, op);
}

}  // namespace

template <class T>
void interpolate_forward(const T* attr, std::int64_t num_vertices, std::int64_t C, const T* clip,
                         const std::int32_t* tris, std::int64_t num_tris, const std::int32_t* tri_id,
                         const T* uv, int width, int height, bool perspective,
                         const typename detail::NoDeduce<T>::type* background, T* out) {
  check_args(num_vertices, C, tris, num_tris, tri_id, width, height, "interpolate");
  const std::int64_t P = static_cast<std::int64_t>(width) * height;
  parallel_for(0, P, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t p = lo; p < hi; ++p) {
      T* o = out + p * C;
      // Background: the given colour, or zeros.
      if (tri_id[p] == 0) {
        for (std::int64_t c = 0; c < C; ++c) o[c] = background ? background[c] : T(0);
        continue;
      }
      const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
      const PixelWeights pw = pixel_weights(clip, tri, uv + 2 * p, perspective);
      // A = sum_k weight_k A_k.
      const T* a0 = attr + tri[0] * C;
      const T* a1 = attr + tri[1] * C;
      const T* a2 = attr + tri[2] * C;
      for (std::int64_t c = 0; c < C; ++c)
        o[c] = static_cast<T>(pw.weight[0] * a0[c] + pw.weight[1] * a1[c] + pw.weight[2] * a2[c]);
    }
  });
}

template <class T>
void interpolate_backward(const T* attr, std::int64_t num_vertices, std::int64_t C, const T* clip,
                          const std::int32_t* tris, std::int64_t num_tris,
                          const std::int32_t* tri_id, const T* uv, int width, int height,
                          bool perspective, const T* grad_out,
                          typename detail::NoDeduce<T>::type* grad_attr,
                          typename detail::NoDeduce<T>::type* grad_clip,
                          typename detail::NoDeduce<T>::type* grad_uv) {
  check_args(num_vertices, C, tris, num_tris, tri_id, width, height, "interpolate backward");
  if (!grad_attr && !grad_clip && !grad_uv) return;
  const std::int64_t P = static_cast<std::int64_t>(width) * height;
  // Only the perspective mode has a gradient to w.
  if (!perspective) grad_clip = nullptr;
  const bool scatter = grad_attr || grad_clip;

  // Pixels in chunks: per-pixel terms in parallel, per-vertex sums in pixel order.
  constexpr std::int64_t kChunk = 32768;
  std::vector<double> weight(3 * kChunk), grad_w(3 * kChunk);
  std::vector<std::uint8_t> live(kChunk);
  for (std::int64_t c0 = 0; c0 < P; c0 += kChunk) {
    const std::int64_t c1 = std::min(P, c0 + kChunk);
    parallel_for(c0, c1, 1024, [&](std::int64_t lo, std::int64_t hi) {
      std::vector<double> value(static_cast<std::size_t>(C));
      for (std::int64_t p = lo; p < hi; ++p) {
        const std::int64_t i = p - c0;
        live[i] = 0;
        if (tri_id[p] == 0) continue;
        const T* g = grad_out + p * C;
        // Zero incoming gradient: skip.
        bool any = false;
        for (std::int64_t c = 0; c < C && !any; ++c) any = g[c] != T(0);
        if (!any) continue;
        live[i] = 1;
        const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
        const PixelWeights pw = pixel_weights(clip, tri, uv + 2 * p, perspective);
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
          // A at this pixel, then G_k = g . (A_k - A) / s.
          for (std::int64_t c = 0; c < C; ++c)
            value[c] = pw.weight[0] * a[0][c] + pw.weight[1] * a[1][c] + pw.weight[2] * a[2][c];
          for (int k = 0; k < 3; ++k) {
            double d = 0.0;
            for (std::int64_t c = 0; c < C; ++c) d += static_cast<double>(g[c]) * (a[k][c] - value[c]);
            const double G = d * pw.inv_s;
            // dL/dlambda_k = G_k / w_k ; dL/dw_k = -G_k q_k / w_k.
            g_lambda[k] = G * pw.inv_w[k];
            grad_w[3 * i + k] = -G * pw.q[k] * pw.inv_w[k];
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
    // Scatter in pixel order: dL/dA_k += weight_k g, dL/dw_k += grad_w_k.
    for (std::int64_t p = c0; p < c1; ++p) {
      const std::int64_t i = p - c0;
      if (!live[i]) continue;
      const std::int32_t* tri = tris + 3 * static_cast<std::int64_t>(tri_id[p] - 1);
      const T* g = grad_out + p * C;
      for (int k = 0; k < 3; ++k) {
        if (grad_attr) {
          T* ga = grad_attr + tri[k] * C;
          const double wk = weight[3 * i + k];
          for (std::int64_t c = 0; c < C; ++c) ga[c] += static_cast<T>(wk * g[c]);
        }
        if (grad_clip) grad_clip[4 * static_cast<std::int64_t>(tri[k]) + 3] += static_cast<T>(grad_w[3 * i + k]);
      }
    }
  }
}

template <class T>
void interpolate_derivatives(const T* attr, std::int64_t num_vertices, std::int64_t C, const T* clip,
                             const std::int32_t* tris, std::int64_t num_tris, const std::int32_t* tri_id,
                             const T* uv, int width, int height, bool perspective, T* d_dx, T* d_dy) {
  check_args(num_vertices, C, tris, num_tris, tri_id, width, height, "interpolate derivatives");
  const std::int64_t P = static_cast<std::int64_t>(width) * height;
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
      for (int k = 0; k < 3; ++k) {
        const T* v = clip + 4 * static_cast<std::int64_t>(tri[k]);
        V[k] = {0.5 * width * (double(v[0]) + v[3]), 0.5 * height * (double(v[3]) - v[1]), double(v[3])};
      }
      detail::HVec cr[3];
      for (int k = 0; k < 3; ++k) cr[k] = detail::cross(V[(k + 1) % 3], V[(k + 2) % 3]);
      const double inv_d = safe_inv(detail::dot(V[0], cr[0]));
      // dlambda_k/dx = w_k c_k.x / D, dlambda_k/dy = w_k c_k.y / D.
      double dlx[3], dly[3];
      for (int k = 0; k < 3; ++k) {
        dlx[k] = V[k].w * cr[k].x * inv_d;
        dly[k] = V[k].w * cr[k].y * inv_d;
      }
      const PixelWeights pw = pixel_weights(clip, tri, uv + 2 * p, perspective);
      const T* a[3] = {attr + tri[0] * C, attr + tri[1] * C, attr + tri[2] * C};
      if (!perspective) {
        // dA/dx = sum_k dlambda_k/dx A_k.
        for (std::int64_t c = 0; c < C; ++c) {
          ox[c] = static_cast<T>(dlx[0] * a[0][c] + dlx[1] * a[1][c] + dlx[2] * a[2][c]);
          oy[c] = static_cast<T>(dly[0] * a[0][c] + dly[1] * a[1][c] + dly[2] * a[2][c]);
        }
        continue;
      }
      // dq_k = dlambda_k / w_k; dA/dx = sum_k dq_k/dx (A_k - A) / s.
      double dqx[3], dqy[3];
      for (int k = 0; k < 3; ++k) {
        dqx[k] = dlx[k] * pw.inv_w[k] * pw.inv_s;
        dqy[k] = dly[k] * pw.inv_w[k] * pw.inv_s;
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

#define GR_INSTANTIATE(T)                                                                          \
  template void interpolate_forward<T>(const T*, std::int64_t, std::int64_t, const T*,            \
                                       const std::int32_t*, std::int64_t, const std::int32_t*,    \
                                       const T*, int, int, bool, const T*, T*);                   \
  template void interpolate_backward<T>(const T*, std::int64_t, std::int64_t, const T*,           \
                                        const std::int32_t*, std::int64_t, const std::int32_t*,   \
                                        const T*, int, int, bool, const T*, T*, T*, T*);   \
  template void interpolate_derivatives<T>(const T*, std::int64_t, std::int64_t, const T*,        \
                                           const std::int32_t*, std::int64_t, const std::int32_t*,\
                                           const T*, int, int, bool, T*, T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
