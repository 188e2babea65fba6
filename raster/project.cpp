// Perspective divide and viewport transform, forward and adjoint side by side.
// Each vertex is independent, so every loop is a parallel_for over vertices.
#include "raster/project.h"

#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/detail/guarded_math.h"

namespace gr::raster {

template <class T>
void wdivide_forward(const T* clip, std::int64_t n, T* ndc) {
  // Refuse w == 0 up front (before writing anything).
  for (std::int64_t i = 0; i < n; ++i)
    if (clip[4 * i + 3] == T(0))
      throw ValueError("wdivide: clip w of vertex " + std::to_string(i) +
                       " is 0; clip against the near plane before dividing");
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const T* c = clip + 4 * i;
      const T inv_w = T(1) / c[3];
      ndc[3 * i + 0] = c[0] * inv_w;
      ndc[3 * i + 1] = c[1] * inv_w;
      ndc[3 * i + 2] = c[2] * inv_w;
    }
  });
}

template <class T>
void wdivide_backward(const T* clip, std::int64_t n, const T* grad_ndc, T* grad_clip) {
  // A non-zero gradient cannot flow through w == 0.
  for (std::int64_t i = 0; i < n; ++i) {
    const T* g = grad_ndc + 3 * i;
    if (clip[4 * i + 3] == T(0) && (g[0] != T(0) || g[1] != T(0) || g[2] != T(0)))
      throw ValueError("wdivide backward: clip w of vertex " + std::to_string(i) +
                       " is 0 but its NDC gradient is not");
  }
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const T* g = grad_ndc + 3 * i;
      // Zero incoming gradient: nothing to add.
      if (g[0] == T(0) && g[1] == T(0) && g[2] == T(0)) continue;
      const T* c = clip + 4 * i;
      T* out = grad_clip + 4 * i;
      const T inv_w = T(1) / c[3];
      // d(x/w)/dx = 1/w ; d(x/w)/dw = -x/w^2 (same for y, z).
      out[0] += g[0] * inv_w;
      out[1] += g[1] * inv_w;
      out[2] += g[2] * inv_w;
      out[3] -= (g[0] * c[0] + g[1] * c[1] + g[2] * c[2]) * inv_w * inv_w;
    }
  });
}

template <class T>
void viewport_forward(const T* ndc, std::int64_t n, int width, int height, T* screen) {
  const T hw = T(0.5) * T(width), hh = T(0.5) * T(height);
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      screen[2 * i + 0] = hw * (T(1) + ndc[3 * i + 0]);
      screen[2 * i + 1] = hh * (T(1) - ndc[3 * i + 1]);
    }
  });
}

template <class T>
void viewport_backward(std::int64_t n, int width, int height, const T* grad_screen, T* grad_ndc) {
  const T hw = T(0.5) * T(width), hh = T(0.5) * T(height);
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      grad_ndc[3 * i + 0] += hw * grad_screen[2 * i + 0];
      grad_ndc[3 * i + 1] -= hh * grad_screen[2 * i + 1];
    }
  });
}

template <class T>
void screen_to_clip_backward(const T* clip, std::int64_t n, int width, int height, const double* grad_screen,
                             int stride, T* grad_clip, bool y_up) {
  // With y_up, -hh's negation cancels the one of y: g.y and the product g.y y
  // are exactly the negated-clip kernel's -g.y and g.y (-y).
  const double hw = 0.5 * width, hh = 0.5 * height, hy = y_up ? hh : -hh;
  parallel_for(0, n, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const double* gs = grad_screen + stride * i;
      const double g[3] = {hw * gs[0], hy * gs[1], stride == 3 ? gs[2] : 0.0};
      if (g[0] == 0.0 && g[1] == 0.0 && g[2] == 0.0) continue;
      const T* c = clip + 4 * i;
      T* out = grad_clip + 4 * i;
      const double inv_w = 1.0 / c[3];
      for (int d = 0; d < 3; ++d) out[d] = detail::finite_cast<T>(out[d] + g[d] * inv_w);
      const double dot = g[0] * c[0] + g[1] * c[1] + g[2] * c[2];
      out[3] = detail::finite_cast<T>(out[3] - dot * inv_w * inv_w);
    }
  });
}

#define GR_INSTANTIATE(T)                                                                   \
  template void wdivide_forward<T>(const T*, std::int64_t, T*);                             \
  template void wdivide_backward<T>(const T*, std::int64_t, const T*, T*);                  \
  template void viewport_forward<T>(const T*, std::int64_t, int, int, T*);                  \
  template void viewport_backward<T>(std::int64_t, int, int, const T*, T*);                 \
  template void screen_to_clip_backward<T>(const T*, std::int64_t, int, int, const double*, int, T*, bool);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
