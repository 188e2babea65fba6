// Soft rasterization (SoftRas, Liu et al., ICCV 2019) and its adjoint, on
// plain arrays (no tape): every pixel blends the triangles near it with a
// sigmoid of their signed screen distance and a softmax over depth.
//
// Per pixel p (centre, screen pixels, y down) and triangle j (screen vertices
// P_k, z_k = z_ndc of the vertices):
//   d_j   = distance from p to the triangle's boundary (nearest edge segment),
//   s_j   = +d_j^2 / sigma inside the triangle, -d_j^2 / sigma outside,
//   D_j   = sigmoid(s_j)                            (soft coverage),
//   lambda_j = p's barycentrics inside; outside, those of the nearest point of
//           the nearest edge: (1 - t) on its first vertex, t on its second,
//   zs_j  = (1 - sum_k lambda_k z_k) / 2            (1 at the near plane, 0 at the far),
//   u_j   = log D_j + zs_j / gamma,   u_b = eps / gamma (the background),
//   w_j   = exp(u_j) / (sum_i exp(u_i) + exp(u_b)), w_b likewise,
//   out   = sum_j w_j C_j + w_b C_b,   C_j = sum_k lambda_k A_k.
// Bounded work: a triangle takes part only where D_j >= kSoftCutoff
// (outside: d^2 <= sigma log((1 - c) / c)), and at most max_faces of them per
// pixel, the nearest by zs (ties: lower triangle index). Triangles with a
// vertex behind the near plane (w <= 0 or z < -w) or of zero screen area are
// not drawn. Where fewer than max_faces triangles are near, out is a smooth
// function of every input, so its gradient is exact (docs/soft_rasterize.md).
#pragma once

#include <cstdint>

namespace gr::raster {

// D below this is treated as 0: the triangle does not reach the pixel.
constexpr double kSoftCutoff = 1e-4;

template <class T>
struct SoftRasterParams {
  const T* clip = nullptr;  // num_vertices x 4
  std::int64_t num_vertices = 0;
  const std::int32_t* tris = nullptr;  // num_tris x 3
  std::int64_t num_tris = 0;
  const T* attr = nullptr;  // num_vertices x channels
  std::int64_t channels = 0;
  const T* background = nullptr;  // channels values
  int width = 0, height = 0;
  double sigma = 1.0;   // pixels^2, > 0
  double gamma = 1e-2;  // > 0
  double eps = 0.0;     // the background's depth score (0 = the far plane)
  int max_faces = 8;    // >= 1
};

// out: H x W x channels.
template <class T>
void soft_rasterize_forward(const SoftRasterParams<T>& p, T* out);

// Where the adjoint accumulates (+=); each may be null.
template <class T>
struct SoftRasterGrads {
  T* clip = nullptr;        // num_vertices x 4
  T* attr = nullptr;        // num_vertices x channels
  T* background = nullptr;  // channels
  double* sigma = nullptr;
  double* gamma = nullptr;
};

// Adjoint for grad_out (H x W x channels). With g the pixel's incoming
// gradient, g_j = g . C_j, g_b = g . C_b, gbar = sum_j w_j g_j + w_b g_b:
//   dL/du_j = w_j (g_j - gbar),  dL/dA_k += w_j lambda_k g,  dL/dC_b += w_b g,
//   dL/dzs_j = dL/du_j / gamma,  dL/dgamma -= (sum_j dL/du_j zs_j + dL/du_b eps) / gamma^2,
//   dL/ds_j = dL/du_j (1 - D_j),  dL/dsigma -= dL/ds_j s_j / sigma,
//   dL/d(d_j^2) = +-dL/ds_j / sigma,
// then through d^2 = |p - q|^2, q = a + t (b - a) on the nearest edge
// (dd^2/da = -2 (p - q)(1 - t), dd^2/db = -2 (p - q) t), the barycentrics
// (inside: edge functions over twice the area, as in rasterize_backward;
// outside: t = (p - a).(b - a) / |b - a|^2 where 0 < t < 1) and the
// viewport and w-divide adjoints. Per-vertex sums are added in pixel order,
// bit-identical for any thread count.
template <class T>
void soft_rasterize_backward(const SoftRasterParams<T>& p, const T* grad_out, const SoftRasterGrads<T>& grads);

}  // namespace gr::raster
