// Texture sampling forward and adjoint. Every filter is reduced to a list of at
// most 8 taps (texel index in the all-levels buffer, weight, d weight/du,
// d weight/dv): the forward sums weight * texel, the uv adjoint sums the weight
// derivatives (bilinear: from the Jacobian the forward saved), the texel
// adjoint scatters weight * g. Samples run in parallel; each texel receives its
// adds in sample order (taps filed by texel band, one task per band), so the
// gradients do not depend on the thread count.
#include "raster/texture.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/error.h"
#include "autodiff/parallel.h"
#include "autodiff/tensor.h"
#include "raster/rasterize_setup.h"  // detail::check_finite

namespace gr::raster {
namespace {

constexpr int kMaxTaps = 8;
constexpr int kAhead = 8;  // samples whose texels are prefetched together
constexpr int kScatterAhead = 32;  // taps ahead whose texel gradients the scatter prefetches

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

// Bilinear lookups that also write d out/du, d out/dv = sum_t dw_t/du texel_t
// (and v) for the adjoint. The taps of kAhead samples come first and their
// texels are prefetched, so the (cache-missing) texel reads overlap.
template <class T>
void bilinear_forward_with_jacobian(const TextureParams<T>& p, T* out, T* uv_jacobian) {
  const std::int64_t C = p.channels;
  parallel_for(0, p.num_samples, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t s0 = lo; s0 < hi; s0 += kAhead) {
      const int n = static_cast<int>(std::min<std::int64_t>(kAhead, hi - s0));
      Taps taps[kAhead];
      for (int i = 0; i < n; ++i) {
        bilinear_taps<true>(p.layout.levels[0], p.uv[2 * (s0 + i)], p.uv[2 * (s0 + i) + 1], p.v_down, 1.0, p.wrap,
                            taps[i]);
        for (int k = 0; k < 4; ++k) __builtin_prefetch(p.tex + taps[i].index[k] * C);
      }
      for (int i = 0; i < n; ++i) {
        const Taps& t = taps[i];
        const T* tx[4];
        for (int k = 0; k < 4; ++k) tx[k] = p.tex + t.index[k] * C;
        T* o = out + (s0 + i) * C;
        T* ju = uv_jacobian + (s0 + i) * 2 * C;
        T* jv = ju + C;
        for (std::int64_t c = 0; c < C; ++c) {
          double a = 0.0, du = 0.0, dv = 0.0;
          for (int k = 0; k < 4; ++k) {
            const double x = tx[k][c];
            a += t.w[k] * x;
            du += t.dw_du[k] * x;
            dv += t.dw_dv[k] * x;
          }
          o[c] = static_cast<T>(a);
          ju[c] = static_cast<T>(du);
          jv[c] = static_cast<T>(dv);
        }
      }
    }
  });
}

}  // namespace

double texture_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height, int levels,
                   double bias, LodRule rule) {
  return compute_lod(du_dx, dv_dx, du_dy, dv_dy, width, height, levels, bias, rule).value;
}

template <class T>
void texture_forward(const TextureParams<T>& p, T* out, T* uv_jacobian) {
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
  if (uv_jacobian && p.filter != Filter::Bilinear)
    throw ValueError("texture: the uv Jacobian is saved for the bilinear filter only");
  if (uv_jacobian) {
    bilinear_forward_with_jacobian(p, out, uv_jacobian);
    return;
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
// One texel gradient to add: dL/d texel += w g_sample. Packed (9 bytes for
// float): the buckets are written once and read once, so their size is time.
template <class T>
struct [[gnu::packed]] TapEntry {
  std::uint32_t texel;  // in the all-levels buffer (below 2^32 for sides <= 32768)
  T w;
  std::uint8_t sample;  // within the block of kBlock samples
};

// The adjoint's per-chunk tap buckets, reused across calls: for every block of
// kBlock samples and every texel band, that block's taps in the band, in
// sample order. Sized for the worst case (all taps of a block in one band).
template <class T>
struct TapBuckets {
  std::vector<TapEntry<T>> entries;
  std::vector<std::int32_t> count;  // [block][band]
};
template <class T>
detail::ScratchPool<TapBuckets<T>> g_bucket_pool;

// Samples x bands whose buckets exist at once (a chunk of 32768 samples with
// two bands): fewer, larger chunks mean fewer fork/joins; the buckets' size
// stays the same for any number of bands.
constexpr std::int64_t kChunkTimesBands = 65536;
constexpr std::int64_t kBlock = 256;   // samples per bucket block (one task; TapEntry::sample fits)

// Texel bands for the scatter: about one per thread, a power of two texels wide
// (band = texel >> shift), so a tap finds its band with a shift.
struct Bands {
  int shift = 0;
  std::int64_t count = 1;
};
Bands texel_bands(std::int64_t texels, std::int64_t threads) {
  Bands b;
  const std::int64_t want = (texels + threads - 1) / std::max<std::int64_t>(1, threads);
  while ((std::int64_t(1) << b.shift) < want) ++b.shift;
  b.count = (texels + (std::int64_t(1) << b.shift) - 1) >> b.shift;
  return b;
}

// True if the sample's incoming gradient has a non-zero channel (a zero one adds nothing).
template <class T>
inline bool live(const T* g, std::int64_t C) {
  for (std::int64_t c = 0; c < C; ++c)
    if (g[c] != T(0)) return true;
  return false;
}
}  // namespace

template <class T>
void texture_backward(const TextureParams<T>& p, const T* grad_out, const TextureGrads<T>& grads,
                      const T* uv_jacobian) {
  check_params(p, "texture backward");
  if (uv_jacobian && p.filter != Filter::Bilinear)
    throw ValueError("texture backward: the uv Jacobian is saved for the bilinear filter only");
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
  const bool reads_texels = (grad_uv && !uv_jacobian) || lod_grads;
  Tensor scratch;
  double* acc = nullptr;
  if (texels && !direct) {
    // Through the storage cache: no fresh pages in an optimization loop.
    scratch = Tensor::zeros({p.layout.total_texels * C}, DType::Float64);
    acc = scratch.data<double>();
  }

  // Samples in chunks, each in blocks of kBlock (one task each):
  // uv gradients and taps in parallel, every tap filed under its texel band;
  // then one task per band adds its taps, block after block. Each texel so
  // sees its adds in sample order whatever the number of bands or threads.
  const int stride = p.filter == Filter::Nearest ? 1 : p.filter == Filter::Trilinear ? kMaxTaps : 4;
  const std::int64_t acc_texels = levels_used == 1 ? base_texels : p.layout.total_texels;
  const Bands bands = texel_bands(acc_texels, std::min(num_threads(), 16));
  const std::int64_t chunk = std::max<std::int64_t>(kBlock, kChunkTimesBands / bands.count / kBlock * kBlock);
  const std::int64_t blocks_per_chunk = (std::min(S, chunk) + kBlock - 1) / kBlock;
  // Pooled, so an optimization loop does not fault in fresh pages every call.
  auto lease = g_bucket_pool<T>.take();
  std::vector<TapEntry<T>>& entries = lease->entries;
  std::vector<std::int32_t>& count = lease->count;
  const std::int64_t bucket_size = kBlock * stride;
  if (texels) {
    entries.resize(static_cast<std::size_t>(blocks_per_chunk * bands.count * bucket_size));
    count.resize(static_cast<std::size_t>(blocks_per_chunk * bands.count));
  }

  for (std::int64_t c0 = 0; c0 < S; c0 += chunk) {
    const std::int64_t c1 = std::min(S, c0 + chunk);
    const std::int64_t blocks = (c1 - c0 + kBlock - 1) / kBlock;
    // dL/du = g . d out/du (likewise v), from the forward's Jacobian.
    auto uv_grad_from_jacobian = [&](std::int64_t s, const T* g) {
      const T* ju = uv_jacobian + s * 2 * C;
      grad_uv[2 * s] += static_cast<T>(dot_channels(g, ju, C));
      grad_uv[2 * s + 1] += static_cast<T>(dot_channels(g, ju + C, C));
    };
    // Files tap (texel, w) of sample s under its texel band in block j's buckets.
    auto file_tap = [&](std::int32_t* counts, std::int64_t j, std::int64_t s, std::int64_t texel, double w) {
      const std::int64_t band = texel >> bands.shift;
      entries[(j * bands.count + band) * bucket_size + counts[band]++] = {
          static_cast<std::uint32_t>(texel), static_cast<T>(w), static_cast<std::uint8_t>(s - c0 - j * kBlock)};
    };
    // Taps of kAhead samples first, their texels prefetched, so that the texel
    // reads after them overlap instead of waiting one by one. Bilinear (the
    // common filter) gets its own instance, with a constant tap count.
    auto tap_block = [&](auto bilinear, std::int64_t j) {
      constexpr bool kBilinear = decltype(bilinear)::value;
      std::int32_t* counts = texels ? &count[j * bands.count] : nullptr;
      if (counts) std::fill(counts, counts + bands.count, 0);
      const std::int64_t s_end = std::min(c1, c0 + (j + 1) * kBlock);
      if constexpr (kBilinear) {
        if (!reads_texels) {
          // The forward saved the uv Jacobian: no texel is read, so the taps
          // need no prefetch group and stay in registers.
          for (std::int64_t s = c0 + j * kBlock; s < s_end; ++s) {
            const T* g = grad_out + s * C;
            if (!live(g, C)) continue;
            if (grad_uv) uv_grad_from_jacobian(s, g);
            if (!texels) continue;
            Taps t;
            bilinear_taps<false>(p.layout.levels[0], p.uv[2 * s], p.uv[2 * s + 1], p.v_down, 1.0, p.wrap, t);
            for (int k = 0; k < 4; ++k) file_tap(counts, j, s, t.index[k], t.w[k]);
          }
          return;
        }
      }
      for (std::int64_t s0 = c0 + j * kBlock; s0 < s_end; s0 += kAhead) {
        const int n = static_cast<int>(std::min<std::int64_t>(kAhead, s_end - s0));
        Taps taps[kAhead];
        bool is_live[kAhead];
        for (int i = 0; i < n; ++i) {
          is_live[i] = live(grad_out + (s0 + i) * C, C);
          if (!is_live[i]) continue;
          if constexpr (kBilinear) {
            const double u = p.uv[2 * (s0 + i)], v = p.uv[2 * (s0 + i) + 1];
            if (reads_texels)  // the weights' uv derivatives are needed
              bilinear_taps<true>(p.layout.levels[0], u, v, p.v_down, 1.0, p.wrap, taps[i]);
            else
              bilinear_taps<false>(p.layout.levels[0], u, v, p.v_down, 1.0, p.wrap, taps[i]);
          } else
            taps[i] = sample_taps<T, true>(p, s0 + i);
          if (reads_texels)
            for (int k = 0; k < (kBilinear ? 4 : taps[i].n); ++k)
              __builtin_prefetch(texel(p, taps[i].index[k], base_texels));
        }
        for (int i = 0; i < n; ++i) {
          if (!is_live[i]) continue;
          const std::int64_t s = s0 + i;
          const Taps& t = taps[i];
          const int nt = kBilinear ? 4 : t.n;
          const T* g = grad_out + s * C;
          if (!kBilinear && lod_grads && t.lod_free) {
            // dL/dlod = g . sum_t (dw_t/dlod) texel_t, then through the LOD.
            double g_lod = 0.0;
            for (int k = 0; k < nt; ++k) g_lod += t.dw_dlod[k] * dot_channels(g, texel(p, t.index[k], base_texels), C);
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
          if (grad_uv && uv_jacobian) {
            uv_grad_from_jacobian(s, g);
          } else if (grad_uv) {
            // dL/du = g . sum_t dw_t/du texel_t (likewise v).
            double gu = 0.0, gv = 0.0;
            for (int k = 0; k < nt; ++k) {
              const double d = dot_channels(g, texel(p, t.index[k], base_texels), C);
              gu += t.dw_du[k] * d;
              gv += t.dw_dv[k] * d;
            }
            grad_uv[2 * s] += static_cast<T>(gu);
            grad_uv[2 * s + 1] += static_cast<T>(gv);
          }
          if (!texels) continue;
          for (int k = 0; k < nt; ++k) file_tap(counts, j, s, t.index[k], t.w[k]);
        }
      }
    };
    parallel_for(0, blocks, 1, [&](std::int64_t j0, std::int64_t j1) {
      for (std::int64_t j = j0; j < j1; ++j) {
        if (p.filter == Filter::Bilinear)
          tap_block(std::true_type{}, j);
        else
          tap_block(std::false_type{}, j);
      }
    });
    if (!texels) continue;
    // dL/d texel_t += w_t g: each band's task walks its buckets block by block.
    auto scatter = [&](auto* sums) {
      parallel_for(0, bands.count, 1, [&](std::int64_t b0, std::int64_t b1) {
        for (std::int64_t b = b0; b < b1; ++b)
          for (std::int64_t j = 0; j < blocks; ++j) {
            const TapEntry<T>* e = &entries[(j * bands.count + b) * bucket_size];
            const std::int32_t n = count[j * bands.count + b];
            for (std::int32_t q = 0; q < n; ++q) {
              if (q + kScatterAhead < n) __builtin_prefetch(sums + e[q + kScatterAhead].texel * C, 1);
              auto* a = sums + e[q].texel * C;
              const T* g = grad_out + (c0 + j * kBlock + e[q].sample) * C;
              const double w = e[q].w;
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
  template void texture_forward<T>(const TextureParams<T>&, T*, T*);                                         \
  template void texture_backward<T>(const TextureParams<T>&, const T*, const TextureGrads<T>&, const T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
