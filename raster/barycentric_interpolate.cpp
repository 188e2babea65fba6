// Linear blend of vertex attributes with stored barycentrics, and its adjoint
// (formulas in barycentric_interpolate.h). The per-vertex scatter gives each
// thread a range of vertices that walks all pixels in order, as
// raster/interpolate.cpp does, so the sums do not depend on the thread count.
#include "raster/barycentric_interpolate.h"

#include <algorithm>

#include "autodiff/parallel.h"

namespace gr::raster {
namespace {

template <class T>
std::int64_t pixel_triangle(const BarycentricInterpolateParams<T>& p, std::int64_t q) {
  // -1 = background
  return p.tri_id ? static_cast<std::int64_t>(p.tri_id[q]) - 1 : static_cast<std::int64_t>(p.rast[4 * q + 3]) - 1;
}

// Weights of the three vertices at pixel q, and their x and y derivatives.
struct Weights {
  double w[3], dx[3], dy[3];
};
template <class T>
Weights pixel_weights(const BarycentricInterpolateParams<T>& p, std::int64_t q) {
  const T* r = p.rast + p.rast_stride * q;
  Weights k;
  k.w[0] = r[0];
  k.w[1] = r[1];
  k.w[2] = 1.0 - k.w[0] - k.w[1];
  if (p.rast_db) {
    const T* d = p.rast_db + 4 * q;
    k.dx[0] = d[0], k.dy[0] = d[1], k.dx[1] = d[2], k.dy[1] = d[3];
    k.dx[2] = -k.dx[0] - k.dx[1];
    k.dy[2] = -k.dy[0] - k.dy[1];
  }
  return k;
}

}  // namespace

template <class T>
void barycentric_interpolate_forward(const BarycentricInterpolateParams<T>& p, T* out, T* out_da) {
  const std::int64_t C = p.channels, K = p.num_diff;
  parallel_for(0, p.pixels, 2048, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t q = lo; q < hi; ++q) {
      T* o = out + q * C;
      T* od = out_da ? out_da + q * 2 * K : nullptr;
      const std::int64_t t = pixel_triangle(p, q);
      if (t < 0) {
        std::fill(o, o + C, T(0));
        if (od) std::fill(od, od + 2 * K, T(0));
        continue;
      }
      const std::int32_t* tri = p.tris + 3 * t;
      const T* a[3] = {p.attr + tri[0] * C, p.attr + tri[1] * C, p.attr + tri[2] * C};
      const Weights k = pixel_weights(p, q);
      for (std::int64_t c = 0; c < C; ++c) o[c] = static_cast<T>(k.w[0] * a[0][c] + k.w[1] * a[1][c] + k.w[2] * a[2][c]);
      if (!od) continue;
      for (std::int64_t j = 0; j < K; ++j) {
        const std::int32_t c = p.diff[j];
        od[2 * j] = static_cast<T>(k.dx[0] * a[0][c] + k.dx[1] * a[1][c] + k.dx[2] * a[2][c]);
        od[2 * j + 1] = static_cast<T>(k.dy[0] * a[0][c] + k.dy[1] * a[1][c] + k.dy[2] * a[2][c]);
      }
    }
  });
}

template <class T>
void barycentric_interpolate_backward(const BarycentricInterpolateParams<T>& p, const T* grad_out,
                                      const T* grad_da, const BarycentricInterpolateGrads<T>& grads) {
  const std::int64_t C = p.channels, K = grad_da ? p.num_diff : 0;
  // Per pixel: gradients of the barycentrics and their derivatives.
  if (grads.rast || grads.rast_db)
    parallel_for(0, p.pixels, 2048, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t q = lo; q < hi; ++q) {
        const std::int64_t t = pixel_triangle(p, q);
        if (t < 0) continue;
        const std::int32_t* tri = p.tris + 3 * t;
        const T* a[3] = {p.attr + tri[0] * C, p.attr + tri[1] * C, p.attr + tri[2] * C};
        if (grads.rast) {
          const T* g = grad_out + q * C;
          double g0 = 0.0, g1 = 0.0;
          for (std::int64_t c = 0; c < C; ++c) {
            g0 += static_cast<double>(g[c]) * (static_cast<double>(a[0][c]) - a[2][c]);
            g1 += static_cast<double>(g[c]) * (static_cast<double>(a[1][c]) - a[2][c]);
          }
          grads.rast[p.rast_stride * q] += static_cast<T>(g0);
          grads.rast[p.rast_stride * q + 1] += static_cast<T>(g1);
        }
        if (grads.rast_db && K > 0) {
          const T* h = grad_da + q * 2 * K;
          double d[4] = {0, 0, 0, 0};
          for (std::int64_t j = 0; j < K; ++j) {
            const std::int32_t c = p.diff[j];
            const double e0 = static_cast<double>(a[0][c]) - a[2][c], e1 = static_cast<double>(a[1][c]) - a[2][c];
            d[0] += h[2 * j] * e0;
            d[1] += h[2 * j + 1] * e0;
            d[2] += h[2 * j] * e1;
            d[3] += h[2 * j + 1] * e1;
          }
          for (int i = 0; i < 4; ++i) grads.rast_db[4 * q + i] += static_cast<T>(d[i]);
        }
      }
    });
  if (!grads.attr) return;
  // Per vertex, in pixel order: each thread owns a range of vertices.
  const std::int64_t N = p.num_vertices;
  const std::int64_t groups = std::max<std::int64_t>(1, std::min<std::int64_t>(num_threads(), N));
  const std::int64_t per_group = (N + groups - 1) / groups;
  parallel_for(0, groups, 1, [&](std::int64_t g0, std::int64_t g1) {
    const std::int64_t v0 = g0 * per_group, v1 = std::min(N, g1 * per_group);
    for (std::int64_t q = 0; q < p.pixels; ++q) {
      const std::int64_t t = pixel_triangle(p, q);
      if (t < 0) continue;
      const std::int32_t* tri = p.tris + 3 * t;
      if ((tri[0] < v0 || tri[0] >= v1) && (tri[1] < v0 || tri[1] >= v1) && (tri[2] < v0 || tri[2] >= v1)) continue;
      const Weights w = pixel_weights(p, q);
      const T* g = grad_out + q * C;
      const T* h = K > 0 ? grad_da + q * 2 * K : nullptr;
      for (int k = 0; k < 3; ++k) {
        if (tri[k] < v0 || tri[k] >= v1) continue;
        T* ga = grads.attr + tri[k] * C;
        for (std::int64_t c = 0; c < C; ++c) ga[c] += static_cast<T>(w.w[k] * g[c]);
        for (std::int64_t j = 0; j < K; ++j)
          ga[p.diff[j]] += static_cast<T>(w.dx[k] * h[2 * j] + w.dy[k] * h[2 * j + 1]);
      }
    }
  });
}

#define GR_INSTANTIATE(T)                                                                                  \
  template void barycentric_interpolate_forward<T>(const BarycentricInterpolateParams<T>&, T*, T*);         \
  template void barycentric_interpolate_backward<T>(const BarycentricInterpolateParams<T>&, const T*, const T*, \
                                                    const BarycentricInterpolateGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
