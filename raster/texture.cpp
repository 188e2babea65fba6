// Texture sampling forward and adjoint. Every filter is reduced to a list of at
// most 8 taps (texel index in the all-levels buffer, weight, d weight/du,
// d weight/dv): the forward sums weight * texel, the uv adjoint sums the weight
// derivatives, the texel adjoint scatters weight * g. Samples run in parallel;
// texel gradients are scattered serially in sample order (fixed chunks), so
// they do not depend on the thread count.
#include "raster/texture.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "autodiff/error.h"
#include "autodiff/parallel.h"
#include "autodiff/tensor.h"
#include "raster/rasterize_setup.h"  // detail::check_finite

namespace gr::raster {
namespace {

constexpr int kMaxTaps = 8;

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

Lod compute_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height, int levels,
                double bias, LodRule rule) {
  // Footprint of one pixel step along x and along y, in level-0 texels.
  Lod l;
  l.ax = du_dx * width, l.ay = dv_dx * height, l.bx = du_dy * width, l.by = dv_dy * height;
  const double A = l.ax * l.ax + l.ay * l.ay, B = l.bx * l.bx + l.by * l.by;
  if (rule == LodRule::Isotropic) {
    const bool along_x = !(A < B);
    l.rho2 = along_x ? A : B;
    (along_x ? l.pA : l.pB) = 1.0;
  } else {
    // Squared major axis of the ellipse with quadratic form [[A, C], [C, B]].
    const double C = l.ax * l.bx + l.ay * l.by, h = 0.5 * (A - B);
    const double r = std::sqrt(h * h + C * C);
    l.rho2 = 0.5 * (A + B) + r;
    l.pA = r > 0 ? 0.5 + 0.5 * h / r : 0.5;
    l.pB = r > 0 ? 0.5 - 0.5 * h / r : 0.5;
    l.pC = r > 0 ? C / r : 0.0;
  }
  const double raw = 0.5 * std::log2(l.rho2) + bias;
  l.free = raw > 0.0 && raw < levels - 1;
  l.value = raw;
  if (!(l.value > 0.0)) l.value = 0.0;  // magnification, zero footprint, NaN
  if (l.value > levels - 1) l.value = levels - 1;
  return l;
}

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
  const double x = u * lv.width - 0.5, y = (v_down ? v : 1.0 - v) * lv.height - 0.5;
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
void check_params(const TextureParams<T>& p, const char* op) {
  if (p.layout.count() < 1 || p.channels < 1 || p.num_samples < 0)
    throw ShapeError(std::string(op) + ": empty texture or negative sample count");
  if (mipmapped(p.filter) && (!p.uv_dx || !p.uv_dy))
    throw ValueError(std::string(op) + ": mipmapped filtering needs uv_dx and uv_dy");
  if (mipmapped(p.filter) && p.layout.count() > 1 && !p.pyramid)
    throw ValueError(std::string(op) + ": mipmapped filtering needs the mip pyramid");
}

}  // namespace

double texture_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height, int levels,
                   double bias, LodRule rule) {
  return compute_lod(du_dx, dv_dx, du_dy, dv_dy, width, height, levels, bias, rule).value;
}

template <class T>
void texture_forward(const TextureParams<T>& p, T* out) {
  check_params(p, "texture");
  const std::int64_t C = p.channels;
  const std::int64_t base_texels = std::int64_t(p.layout.levels[0].height) * p.layout.levels[0].width;
  // A NaN texel would turn every sample whose footprint touches it (and, through
  // the mip pyramid, whole regions of coarser levels) into NaN.
  detail::check_finite(p.tex, base_texels * C, "tex", "texture");
  detail::check_finite(p.uv, 2 * p.num_samples, "uv", "texture");
  if (mipmapped(p.filter)) {
    detail::check_finite(p.uv_dx, 2 * p.num_samples, "uv_dx", "texture");
    detail::check_finite(p.uv_dy, 2 * p.num_samples, "uv_dy", "texture");
    if (p.mip_level_bias) detail::check_finite(p.mip_level_bias, p.num_samples, "mip_level_bias", "texture");
  }
  parallel_for(0, p.num_samples, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t s = lo; s < hi; ++s) {
      const Taps t = sample_taps<T, false>(p, s);
      T* o = out + s * C;
      // out = sum_t w_t texel_t (channel-outer: the taps' pointers stay in registers).
      const T* tx[kMaxTaps];
      for (int k = 0; k < t.n; ++k) tx[k] = texel(p, t.index[k], base_texels);
      for (std::int64_t c = 0; c < C; ++c) {
        double a = 0.0;
        for (int k = 0; k < t.n; ++k) a += t.w[k] * tx[k][c];
        o[c] = static_cast<T>(a);
      }
    }
  });
}

namespace {
// The adjoint's per-chunk tap buffers, reused across calls: texel index (in
// the all-levels buffer: below 2^32 for sides <= 32768) and weight in T.
template <class T>
struct TapScratch {
  std::vector<std::uint32_t> index;
  std::vector<T> w;
  std::vector<std::uint8_t> n;
};
template <class T>
detail::ScratchPool<TapScratch<T>> g_tap_pool;
}  // namespace

template <class T>
void texture_backward(const TextureParams<T>& p, const T* grad_out, const TextureGrads<T>& grads) {
  check_params(p, "texture backward");
  T* grad_tex = grads.tex;
  T* grad_uv = p.filter == Filter::Nearest ? nullptr : grads.uv;  // nearest: piecewise constant in uv
  const bool trilinear = p.filter == Filter::Trilinear;
  T* grad_dx = trilinear ? grads.uv_dx : nullptr;
  T* grad_dy = trilinear ? grads.uv_dy : nullptr;
  T* grad_bias = trilinear ? grads.mip_level_bias : nullptr;
  const bool lod_grads = grad_dx || grad_dy || grad_bias;
  T* grad_pyramid = mipmapped(p.filter) && p.user_pyramid ? grads.pyramid : nullptr;
  if (!grad_tex && !grad_uv && !lod_grads && !grad_pyramid) return;
  const std::int64_t C = p.channels, S = p.num_samples;
  const std::int64_t base_texels = std::int64_t(p.layout.levels[0].height) * p.layout.levels[0].width;
  const int levels_used = mipmapped(p.filter) ? p.layout.count() : 1;

  // Texel gradients: level 0 alone straight into grad_tex (summed in T); with
  // mip levels, every level's in double, then down the pyramid.
  const bool texels = grad_tex || grad_pyramid;
  const bool direct = levels_used == 1 && grad_tex;
  Tensor scratch;
  double* acc = nullptr;
  if (texels && !direct) {
    // Through the storage cache: no fresh pages in an optimization loop.
    scratch = Tensor::zeros({p.layout.total_texels * C}, DType::Float64);
    acc = scratch.data<double>();
  }

  // Samples in chunks: taps and uv gradients in parallel, texel sums in sample
  // order. Taps are kept compactly (index, weight) with a fixed stride, and a
  // chunk's taps (64-128 KiB) stay in L2 between the two passes.
  constexpr std::int64_t kChunk = 4096;
  const int stride = p.filter == Filter::Nearest ? 1 : p.filter == Filter::Trilinear ? kMaxTaps : 4;
  const std::size_t chunk = static_cast<std::size_t>(std::min(S, kChunk));
  // Pooled, so an optimization loop does not fault in fresh pages every call.
  auto lease = g_tap_pool<T>.take();
  std::vector<std::uint32_t>& tap_index = lease->index;
  std::vector<T>& tap_w = lease->w;
  std::vector<std::uint8_t>& tap_n = lease->n;  // 0: sample skipped
  if (texels) {
    tap_index.resize(stride * chunk);
    tap_w.resize(stride * chunk);
  }
  tap_n.resize(chunk);
  const std::int64_t acc_texels = levels_used == 1 ? base_texels : p.layout.total_texels;
  const std::int64_t bands = std::max(1, num_threads());
  const std::int64_t band_size = (acc_texels + bands - 1) / bands;
  for (std::int64_t c0 = 0; c0 < S; c0 += kChunk) {
    const std::int64_t c1 = std::min(S, c0 + kChunk);
    parallel_for(c0, c1, 1024, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t s = lo; s < hi; ++s) {
        const std::int64_t i = s - c0;
        const T* g = grad_out + s * C;
        // Zero incoming gradient: skip.
        bool any = false;
        for (std::int64_t c = 0; c < C && !any; ++c) any = g[c] != T(0);
        tap_n[i] = 0;
        if (!any) continue;
        const Taps t = sample_taps<T, true>(p, s);
        if (lod_grads && t.lod_free) {
          // dL/dlod = g . sum_t (dw_t/dlod) texel_t, then through the LOD.
          double g_lod = 0.0;
          for (int k = 0; k < t.n; ++k) g_lod += t.dw_dlod[k] * dot_channels(g, texel(p, t.index[k], base_texels), C);
          if (grad_bias) grad_bias[s] += static_cast<T>(g_lod);
          const MipLevel& base = p.layout.levels[0];
          const Lod l = compute_lod(p.uv_dx[2 * s], p.uv_dx[2 * s + 1], p.uv_dy[2 * s], p.uv_dy[2 * s + 1],
                                    base.width, base.height, p.layout.count(), 0.0, p.lod_rule);
          // k = dL/dlod dlod/drho2 * 2 = dL/dlod / (rho2 ln 2); dA/d(du/dx) = 2 a_x W, dC/d(du/dx) = b_x W, ...
          const double k = g_lod / (l.rho2 * std::log(2.0));
          if (grad_dx && (l.pA != 0.0 || l.pC != 0.0)) {
            grad_dx[2 * s] += static_cast<T>(k * (l.pA * l.ax + 0.5 * l.pC * l.bx) * base.width);
            grad_dx[2 * s + 1] += static_cast<T>(k * (l.pA * l.ay + 0.5 * l.pC * l.by) * base.height);
          }
          if (grad_dy && (l.pB != 0.0 || l.pC != 0.0)) {
            grad_dy[2 * s] += static_cast<T>(k * (l.pB * l.bx + 0.5 * l.pC * l.ax) * base.width);
            grad_dy[2 * s + 1] += static_cast<T>(k * (l.pB * l.by + 0.5 * l.pC * l.ay) * base.height);
          }
        }
        if (grad_uv) {
          // dL/du = g . sum_t dw_t/du texel_t (likewise v).
          double gu = 0.0, gv = 0.0;
          for (int k = 0; k < t.n; ++k) {
            const double d = dot_channels(g, texel(p, t.index[k], base_texels), C);
            gu += t.dw_du[k] * d;
            gv += t.dw_dv[k] * d;
          }
          grad_uv[2 * s] += static_cast<T>(gu);
          grad_uv[2 * s + 1] += static_cast<T>(gv);
        }
        tap_n[i] = static_cast<std::uint8_t>(t.n);
        if (!texels) continue;
        for (int k = 0; k < t.n; ++k) {
          tap_index[stride * i + k] = static_cast<std::uint32_t>(t.index[k]);
          tap_w[stride * i + k] = static_cast<T>(t.w[k]);
        }
      }
    });
    if (!texels) continue;
    // Scatter in sample order: dL/d texel_t += w_t g. The texels are split
    // into bands, one task each; every task walks all taps in sample order and
    // applies those in its band, so each texel sees the same sequence of adds
    // whatever the number of bands or threads.
    auto scatter = [&](auto* sums) {
      parallel_for(0, bands, 1, [&](std::int64_t b0, std::int64_t b1) {
        const std::int64_t lo = band_size * b0, hi = std::min(acc_texels, band_size * b1);
        for (std::int64_t s = c0; s < c1; ++s) {
          const std::int64_t i = s - c0;
          const int n = tap_n[i];
          const T* g = grad_out + s * C;
          for (int k = 0; k < n; ++k) {
            const std::int64_t t = tap_index[stride * i + k];
            if (t < lo || t >= hi) continue;
            auto* a = sums + t * C;
            const double w = tap_w[stride * i + k];
            for (std::int64_t c = 0; c < C; ++c) a[c] += w * g[c];
          }
        }
      });
    };
    if (direct)
      scatter(grad_tex);
    else
      scatter(acc);
  }
  if (!texels || direct) return;
  if (p.user_pyramid) {
    // The user's levels keep their own gradients.
    if (grad_pyramid)
      parallel_for(base_texels * C, acc_texels * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t k = lo; k < hi; ++k) grad_pyramid[k - base_texels * C] += static_cast<T>(acc[k]);
      });
  } else if (levels_used > 1) {
    mip_backward(C, p.layout, acc);  // every level's gradient down to level 0
  }
  if (!grad_tex) return;
  parallel_for(0, base_texels * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t k = lo; k < hi; ++k) grad_tex[k] += static_cast<T>(acc[k]);
  });
}

#define GR_INSTANTIATE(T)                                                   \
  template void texture_forward<T>(const TextureParams<T>&, T*);            \
  template void texture_backward<T>(const TextureParams<T>&, const T*, const TextureGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
