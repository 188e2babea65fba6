// Texture sampling's taps (internal to raster/texture.cpp and
// raster/texture_backward.cpp): every filter reduced to a list of at most 8
// taps (texel index in the all-levels buffer, weight, d weight/du, d
// weight/dv, d weight/dlod), the level of detail and its partials, texel
// addressing, and the checks both directions make.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "autodiff/base/error.h"
#include "raster/texture.h"

namespace gr::raster::texture_taps {

inline constexpr int kMaxTaps = 8;
inline constexpr int kAhead = 8;  // samples whose texels are prefetched together

struct Taps {
  int n = 0;
  std::int64_t index[kMaxTaps];  // texel in the all-levels buffer (level offset + row * W + column)
  double w[kMaxTaps], dw_du[kMaxTaps], dw_dv[kMaxTaps];
  double dw_dlod[kMaxTaps];  // trilinear: -bilinear weight on level l0, + on level l0 + 1
  bool lod_free = false;     // trilinear: the LOD is not clamped, so it has a derivative
};

// The LOD and what its derivative needs: the unclamped log2 footprint plus the
// bias, and the partials of rho2 w.r.t. A = |a|^2, B = |b|^2, C = a.b.
struct Lod {
  double value = 0;   // clamped to [0, levels - 1]
  bool free = false;  // 0 < unclamped < levels - 1
  double rho2 = 0;
  double pA = 0, pB = 0, pC = 0;
  double ax = 0, ay = 0, bx = 0, by = 0;
};

// The LOD of a sample (texture_lod's formula, raster/texture.h) and its partials.
Lod compute_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height, int levels,
                double bias, LodRule rule);

// Address of integer texel index i (a whole number held in a double) along an
// axis of n texels. The final clamp keeps any input (huge, NaN) in range.
[[gnu::always_inline]] inline std::int64_t address(double i, int n, Wrap wrap) {
  if (i >= 0.0 && i < n) return static_cast<std::int64_t>(i);  // inside: every mode agrees
  double r = i;
  if (wrap == Wrap::Repeat) {
    // One period out (the common case near a seam) without a division.
    r = i < 0.0 && i >= -n ? i + n : i >= n && i < 2.0 * n ? i - n : i - n * std::floor(i / n);
  } else if (wrap == Wrap::Mirror) {
    const double period = 2.0 * n;
    r = i - period * std::floor(i / period);
    if (r >= n) r = period - 1.0 - r;
  }
  if (!(r >= 0.0)) r = 0.0;
  if (r > n - 1) r = n - 1;
  return static_cast<std::int64_t>(r);
}

// True if integer texel index i lies in [0, n).
[[gnu::always_inline]] inline bool inside(double i, int n) { return i >= 0.0 && i < n; }

// Bilinear taps of level `lv` at (u, v), scaled by the level weight `scale`.
// lod_sign: the sign of d(level weight)/d lod (-1 for level l0, +1 for l0 + 1, 0 without trilinear).
template <bool kDerivatives>
[[gnu::always_inline]] inline void bilinear_taps(const MipLevel& lv, double u, double v, bool v_down, double scale,
                                                 Wrap wrap, Taps& t, double lod_sign = 0.0) {
  // Continuous texel coordinates: x = u W - 0.5, y = (1 - v) H - 0.5 (v_down: v H - 0.5).
  // float64 uv near DBL_MAX overflows them to +-Inf, whose fraction x - floor(x)
  // is NaN: held at +-DBL_MAX (a whole number, fraction 0) like any huge finite uv.
  constexpr double kMax = std::numeric_limits<double>::max();
  const double x = std::clamp(u * lv.width - 0.5, -kMax, kMax);
  const double y = std::clamp((v_down ? v : 1.0 - v) * lv.height - 0.5, -kMax, kMax);
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double fx = x - x0, fy = y - y0;
  const std::int64_t ix[2] = {address(x0, lv.width, wrap), address(x0 + 1.0, lv.width, wrap)};
  const std::int64_t iy[2] = {address(y0, lv.height, wrap), address(y0 + 1.0, lv.height, wrap)};
  // Zero: a tap outside the texture reads 0 (weight 0 on any valid texel).
  const bool zero = wrap == Wrap::Zero;
  const bool in_x[2] = {!zero || inside(x0, lv.width), !zero || inside(x0 + 1.0, lv.width)};
  const bool in_y[2] = {!zero || inside(y0, lv.height), !zero || inside(y0 + 1.0, lv.height)};
  // Weights and their derivatives: dfx/du = W, dfy/dv = -H (v_down: +H).
  const double wx[2] = {1.0 - fx, fx}, wy[2] = {1.0 - fy, fy};
  const double dwx[2] = {-double(lv.width), double(lv.width)};
  const double hy = v_down ? -double(lv.height) : double(lv.height);
  const double dwy[2] = {hy, -hy};
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      const int k = t.n++;
      const double s = in_x[a] && in_y[b] ? scale : 0.0;
      t.index[k] = lv.offset + iy[b] * lv.width + ix[a];
      t.w[k] = s * wx[a] * wy[b];
      if (kDerivatives) {
        t.dw_du[k] = s * dwx[a] * wy[b];
        t.dw_dv[k] = s * wx[a] * dwy[b];
        t.dw_dlod[k] = s == 0.0 ? 0.0 : lod_sign * wx[a] * wy[b];
      }
    }
}

// Taps of sample s; the weight derivatives only when kDerivatives.
template <class T, bool kDerivatives>
[[gnu::always_inline]] inline Taps sample_taps(const TextureParams<T>& p, std::int64_t s) {
  Taps t;
  const double u = p.uv[2 * s], v = p.uv[2 * s + 1];
  const MipLevel& base = p.layout.levels[0];
  switch (p.filter) {
    case Filter::Nearest: {
      // Texel containing (x + 0.5, y + 0.5): floor(u W), floor((1 - v) H) (v_down: floor(v H)).
      const double fx = std::floor(u * base.width), fy = std::floor((p.v_down ? v : 1.0 - v) * base.height);
      const std::int64_t ix = address(fx, base.width, p.wrap);
      const std::int64_t iy = address(fy, base.height, p.wrap);
      t.n = 1;
      t.index[0] = iy * base.width + ix;
      t.w[0] = p.wrap != Wrap::Zero || (inside(fx, base.width) && inside(fy, base.height)) ? 1.0 : 0.0;
      t.dw_du[0] = t.dw_dv[0] = t.dw_dlod[0] = 0.0;
      break;
    }
    case Filter::Bilinear: bilinear_taps<kDerivatives>(base, u, v, p.v_down, 1.0, p.wrap, t); break;
    case Filter::Trilinear: {
      const int L = p.layout.count();
      const Lod lod = compute_lod(p.uv_dx[2 * s], p.uv_dx[2 * s + 1], p.uv_dy[2 * s], p.uv_dy[2 * s + 1],
                                  base.width, base.height, L, p.mip_level_bias ? double(p.mip_level_bias[s]) : 0.0,
                                  p.lod_rule);
      // Levels floor(lod) and floor(lod) + 1, weights 1 - f and f. For the
      // derivatives, level l0 + 1 is kept at f = 0 too (its taps give dw/dlod).
      const int l0 = std::min(static_cast<int>(lod.value), L - 1);
      const double f = l0 == L - 1 ? 0.0 : lod.value - l0;
      bilinear_taps<kDerivatives>(p.layout.levels[l0], u, v, p.v_down, 1.0 - f, p.wrap, t, -1.0);
      if (f > 0.0 || (kDerivatives && lod.free))
        bilinear_taps<kDerivatives>(p.layout.levels[l0 + 1], u, v, p.v_down, f, p.wrap, t, 1.0);
      t.lod_free = lod.free;
      break;
    }
    case Filter::LinearMipmapNearest: {
      const int L = p.layout.count();
      const Lod lod = compute_lod(p.uv_dx[2 * s], p.uv_dx[2 * s + 1], p.uv_dy[2 * s], p.uv_dy[2 * s + 1],
                                  base.width, base.height, L, p.mip_level_bias ? double(p.mip_level_bias[s]) : 0.0,
                                  p.lod_rule);
      bilinear_taps<kDerivatives>(p.layout.levels[std::min(static_cast<int>(lod.value), L - 1)], u, v, p.v_down, 1.0,
                                  p.wrap, t);
      break;
    }
  }
  return t;
}

// Texels of level 0 (the texture itself).
template <class T>
inline std::int64_t base_texel_count(const TextureParams<T>& p) {
  return std::int64_t(p.layout.levels[0].height) * p.layout.levels[0].width;
}

// Texel `index` of the all-levels buffer: level 0 from tex, the rest from pyramid.
template <class T>
inline const T* texel(const TextureParams<T>& p, std::int64_t index, std::int64_t base_texels) {
  return index < base_texels ? p.tex + index * p.channels : p.pyramid + (index - base_texels) * p.channels;
}

// g . texel over C channels, summed in double in channel order.
template <class T>
inline double dot_channels(const T* g, const T* tx, std::int64_t C) {
  double d = 0.0;
  for (std::int64_t c = 0; c < C; ++c) d += static_cast<double>(g[c]) * tx[c];
  return d;
}

template <class T>
inline void check_params(const TextureParams<T>& p, const char* op) {
  if (p.layout.count() < 1 || p.channels < 1 || p.num_samples < 0)
    throw ShapeError(std::string(op) + ": empty texture or negative sample count");
  if (mipmapped(p.filter) && (!p.uv_dx || !p.uv_dy))
    throw ValueError(std::string(op) + ": mipmapped filtering needs uv_dx and uv_dy");
  if (mipmapped(p.filter) && p.layout.count() > 1 && !p.pyramid)
    throw ValueError(std::string(op) + ": mipmapped filtering needs the mip pyramid");
}

}  // namespace gr::raster::texture_taps
