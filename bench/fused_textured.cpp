#include "fused_textured.h"

#include <algorithm>
#include <cmath>

#include "autodiff/base/parallel.h"

namespace gr::bench {
namespace {

// Repeat addressing of integer texel index i along n texels.
inline std::int64_t repeat(std::int64_t i, std::int64_t n) {
  const std::int64_t r = i % n;
  return r < 0 ? r + n : r;
}

// Bilinear footprint of (u, v): texel columns x0, x1, rows y0, y1 and the
// fractions (texel x = u W - 0.5, y = (1 - v) H - 0.5, as the texture op).
template <class T>
struct Footprint {
  std::int64_t x0, x1, y0, y1;
  T fx, fy;
};

template <class T>
Footprint<T> footprint(T u, T v, std::int64_t w, std::int64_t h) {
  const double x = double(u) * w - 0.5, y = (1.0 - double(v)) * h - 0.5;
  const double xf = std::floor(x), yf = std::floor(y);
  const auto xi = static_cast<std::int64_t>(xf), yi = static_cast<std::int64_t>(yf);
  return {repeat(xi, w), repeat(xi + 1, w), repeat(yi, h), repeat(yi + 1, h), T(x - xf), T(y - yf)};
}

}  // namespace

template <class T>
void fused_textured(const TexturedScene& scene, FusedTexturedGradients<T>& out) {
  const std::int64_t n = scene.uv.size(0), h = scene.tex.size(0), w = scene.tex.size(1);
  const T *tex = scene.tex.data<T>(), *uv = scene.uv.data<T>(), *shade = scene.shade.data<T>(),
          *target = scene.target.data<T>();
  out.uv.resize(2 * n);
  out.tex.assign(h * w * 3, T(0));
  out.g.resize(3 * n);
  T *g_uv = out.uv.data(), *g_col = out.g.data();
  const T scale = T(2.0 / (3.0 * double(n)));  // d mean(r^2) / d r = 2 r / (3N)

  // Pass 1: lookup, residual, dL/d(colour) and dL/d(u, v) per pixel.
  const double loss = deterministic_sum<double>(n, 16384, [&](std::int64_t lo, std::int64_t hi) {
    double part = 0;
    for (std::int64_t i = lo; i < hi; ++i) {
      const Footprint<T> f = footprint(uv[2 * i], uv[2 * i + 1], w, h);
      const T *t00 = tex + 3 * (f.y0 * w + f.x0), *t01 = tex + 3 * (f.y0 * w + f.x1);
      const T *t10 = tex + 3 * (f.y1 * w + f.x0), *t11 = tex + 3 * (f.y1 * w + f.x1);
      T du = 0, dv = 0;
      for (int c = 0; c < 3; ++c) {
        const T top = t00[c] + f.fx * (t01[c] - t00[c]), bottom = t10[c] + f.fx * (t11[c] - t10[c]);
        const T colour = top + f.fy * (bottom - top);
        const T r = colour * shade[i] - target[3 * i + c];
        part += double(r) * r;
        const T g = r * scale * shade[i];
        g_col[3 * i + c] = g;
        // d colour/dx = lerp_y(t01 - t00, t11 - t10), dx/du = W; d colour/dy = bottom - top, dy/dv = -H.
        du += g * ((t01[c] - t00[c]) + f.fy * ((t11[c] - t10[c]) - (t01[c] - t00[c])));
        dv += g * (bottom - top);
      }
      g_uv[2 * i] = du * T(w);
      g_uv[2 * i + 1] = -dv * T(h);
    }
    return part;
  });
  out.loss = T(loss / (3.0 * double(n)));

  // Pass 2: dL/d texel += w_t g, one band of texel rows per task.
  const std::int64_t bands = std::min<std::int64_t>(num_threads(), h);
  T* g_tex = out.tex.data();
  parallel_for(0, bands, 1, [&](std::int64_t b0, std::int64_t b1) {
    const std::int64_t row_lo = b0 * h / bands, row_hi = b1 * h / bands;
    auto add = [&](std::int64_t row, std::int64_t col, T weight, const T* g) {
      if (row < row_lo || row >= row_hi) return;
      T* a = g_tex + 3 * (row * w + col);
      for (int c = 0; c < 3; ++c) a[c] += weight * g[c];
    };
    for (std::int64_t i = 0; i < n; ++i) {
      const Footprint<T> f = footprint(uv[2 * i], uv[2 * i + 1], w, h);
      const T* g = g_col + 3 * i;
      add(f.y0, f.x0, (1 - f.fx) * (1 - f.fy), g);
      add(f.y0, f.x1, f.fx * (1 - f.fy), g);
      add(f.y1, f.x0, (1 - f.fx) * f.fy, g);
      add(f.y1, f.x1, f.fx * f.fy, g);
    }
  });
}

template void fused_textured<float>(const TexturedScene&, FusedTexturedGradients<float>&);
template void fused_textured<double>(const TexturedScene&, FusedTexturedGradients<double>&);

}  // namespace gr::bench
