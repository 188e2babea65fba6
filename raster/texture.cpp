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

// Texels of level 0 (the texture itself).
template <class T>
std::int64_t base_texel_count(const TextureParams<T>& p) {
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
  const std::int64_t base_texels = base_texel_count(p);
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

// The gradients one backward call writes: nullptr where the caller asks for
// none or the filter gives none (nearest: uv, piecewise constant; uv_dx, uv_dy
// and the bias only through trilinear's LOD; the user's levels only when
// mipmapped).
template <class T>
struct WantedGrads {
  T* tex;
  T* uv;
  T* uv_dx;
  T* uv_dy;
  T* bias;
  T* pyramid;
  bool lod;     // uv_dx, uv_dy or the bias
  bool texels;  // tex or the user's levels: taps are filed and scattered
};

template <class T>
WantedGrads<T> wanted_grads(const TextureParams<T>& p, const TextureGrads<T>& grads) {
  const bool trilinear = p.filter == Filter::Trilinear;
  WantedGrads<T> w;
  w.tex = grads.tex;
  w.uv = p.filter == Filter::Nearest ? nullptr : grads.uv;
  w.uv_dx = trilinear ? grads.uv_dx : nullptr;
  w.uv_dy = trilinear ? grads.uv_dy : nullptr;
  w.bias = trilinear ? grads.mip_level_bias : nullptr;
  w.pyramid = mipmapped(p.filter) && p.user_pyramid ? grads.pyramid : nullptr;
  w.lod = w.uv_dx || w.uv_dy || w.bias;
  w.texels = w.tex || w.pyramid;
  return w;
}

// The adjoint's samples in chunks, each in blocks of kBlock (one task each):
// uv and LOD gradients and taps in parallel, every tap filed under its texel
// band (gradients_and_taps); then one task per band adds its taps, block after
// block (scatter). Each texel so sees its adds in sample order whatever the
// number of bands or threads.
template <class T>
struct TapPass {
  const TextureParams<T>& p;
  const T* grad_out;
  const T* uv_jacobian;
  WantedGrads<T> want;
  std::int64_t C, base_texels;
  bool reads_texels;  // the uv gradient (without the Jacobian) or the LOD gradients read texels
  Bands bands;
  std::int64_t chunk, bucket_size;
  TapEntry<T>* entries;  // [block][band][bucket_size], valid when want.texels
  std::int32_t* count;   // [block][band]

  // Sizes the chunks and (texel gradients wanted) the buckets of one chunk.
  TapPass(const TextureParams<T>& params, const T* g, const T* jacobian, const WantedGrads<T>& w,
          std::int64_t acc_texels, TapBuckets<T>& buckets)
      : p(params), grad_out(g), uv_jacobian(jacobian), want(w), C(params.channels) {
    base_texels = base_texel_count(p);
    reads_texels = (want.uv && !uv_jacobian) || want.lod;
    const int stride = p.filter == Filter::Nearest ? 1 : p.filter == Filter::Trilinear ? kMaxTaps : 4;
    bands = texel_bands(acc_texels, std::min(num_threads(), 16));
    chunk = std::max<std::int64_t>(kBlock, kChunkTimesBands / bands.count / kBlock * kBlock);
    const std::int64_t blocks_per_chunk = (std::min(p.num_samples, chunk) + kBlock - 1) / kBlock;
    bucket_size = kBlock * stride;
    if (want.texels) {
      buckets.entries.resize(static_cast<std::size_t>(blocks_per_chunk * bands.count * bucket_size));
      buckets.count.resize(static_cast<std::size_t>(blocks_per_chunk * bands.count));
    }
    entries = buckets.entries.data();
    count = buckets.count.data();
  }

  // dL/du = g . d out/du (likewise v), from the forward's Jacobian.
  [[gnu::always_inline]] inline void uv_grad_from_jacobian(std::int64_t s, const T* g) const {
    const T* ju = uv_jacobian + s * 2 * C;
    want.uv[2 * s] += static_cast<T>(dot_channels(g, ju, C));
    want.uv[2 * s + 1] += static_cast<T>(dot_channels(g, ju + C, C));
  }

  // dL/du = g . sum_t dw_t/du texel_t (likewise v).
  [[gnu::always_inline]] inline void uv_grad_from_texels(std::int64_t s, const T* g, const Taps& t, int nt) const {
    double gu = 0.0, gv = 0.0;
    for (int k = 0; k < nt; ++k) {
      const double d = dot_channels(g, texel(p, t.index[k], base_texels), C);
      gu += t.dw_du[k] * d;
      gv += t.dw_dv[k] * d;
    }
    want.uv[2 * s] += static_cast<T>(gu);
    want.uv[2 * s + 1] += static_cast<T>(gv);
  }

  // dL/dlod = g . sum_t (dw_t/dlod) texel_t, then through the LOD to the bias,
  // uv_dx and uv_dy (a trilinear sample whose LOD is not clamped).
  [[gnu::always_inline]] inline void lod_grads(std::int64_t s, const T* g, const Taps& t, int nt) const {
    double g_lod = 0.0;
    for (int k = 0; k < nt; ++k) g_lod += t.dw_dlod[k] * dot_channels(g, texel(p, t.index[k], base_texels), C);
    if (want.bias) want.bias[s] += static_cast<T>(g_lod);
    const MipLevel& base = p.layout.levels[0];
    const Lod l = compute_lod(p.uv_dx[2 * s], p.uv_dx[2 * s + 1], p.uv_dy[2 * s], p.uv_dy[2 * s + 1], base.width,
                              base.height, p.layout.count(), 0.0, p.lod_rule);
    // k = dL/dlod dlod/drho2 * 2 = dL/dlod / (rho2 ln 2); dA/d(du/dx) = 2 a_x W, dC/d(du/dx) = b_x W, ...
    const double k = g_lod / (l.rho2 * std::log(2.0));
    if (want.uv_dx && (l.pA != 0.0 || l.pC != 0.0)) {
      want.uv_dx[2 * s] += static_cast<T>(k * (l.pA * l.ax + 0.5 * l.pC * l.bx) * base.width);
      want.uv_dx[2 * s + 1] += static_cast<T>(k * (l.pA * l.ay + 0.5 * l.pC * l.by) * base.height);
    }
    if (want.uv_dy && (l.pB != 0.0 || l.pC != 0.0)) {
      want.uv_dy[2 * s] += static_cast<T>(k * (l.pB * l.bx + 0.5 * l.pC * l.ax) * base.width);
      want.uv_dy[2 * s + 1] += static_cast<T>(k * (l.pB * l.by + 0.5 * l.pC * l.ay) * base.height);
    }
  }

  // Files tap (texel, w) of sample s under its texel band in block j's buckets
  // (chunk from c0).
  [[gnu::always_inline]] inline void file_tap(std::int32_t* counts, std::int64_t c0, std::int64_t j, std::int64_t s,
                                              std::int64_t texel, double w) const {
    const std::int64_t band = texel >> bands.shift;
    entries[(j * bands.count + band) * bucket_size + counts[band]++] = {
        static_cast<std::uint32_t>(texel), static_cast<T>(w), static_cast<std::uint8_t>(s - c0 - j * kBlock)};
  }

  // Bilinear that reads no texel (the uv gradient from the forward's Jacobian,
  // or none): the taps need no prefetch group and stay in registers.
  void jacobian_block(std::int64_t c0, std::int64_t j, std::int64_t s_end, std::int32_t* counts) const {
    for (std::int64_t s = c0 + j * kBlock; s < s_end; ++s) {
      const T* g = grad_out + s * C;
      if (!live(g, C)) continue;
      if (want.uv) uv_grad_from_jacobian(s, g);
      if (!want.texels) continue;
      Taps t;
      bilinear_taps<false>(p.layout.levels[0], p.uv[2 * s], p.uv[2 * s + 1], p.v_down, 1.0, p.wrap, t);
      for (int k = 0; k < 4; ++k) file_tap(counts, c0, j, s, t.index[k], t.w[k]);
    }
  }

  // Taps of kAhead samples first, their texels prefetched, so that the texel
  // reads after them overlap instead of waiting one by one. Bilinear (the
  // common filter) gets its own instance, with a constant tap count.
  template <bool kBilinear>
  void prefetched_block(std::int64_t c0, std::int64_t j, std::int64_t s_end, std::int32_t* counts) const {
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
        if (!kBilinear && want.lod && t.lod_free) lod_grads(s, g, t, nt);
        if (want.uv && uv_jacobian)
          uv_grad_from_jacobian(s, g);
        else if (want.uv)
          uv_grad_from_texels(s, g, t, nt);
        if (!want.texels) continue;
        for (int k = 0; k < nt; ++k) file_tap(counts, c0, j, s, t.index[k], t.w[k]);
      }
    }
  }

  // Block j of the chunk [c0, c1): its uv and LOD gradients, and its taps filed.
  template <bool kBilinear>
  void tap_block(std::int64_t c0, std::int64_t c1, std::int64_t j) const {
    std::int32_t* counts = want.texels ? &count[j * bands.count] : nullptr;
    if (counts) std::fill(counts, counts + bands.count, 0);
    const std::int64_t s_end = std::min(c1, c0 + (j + 1) * kBlock);
    if constexpr (kBilinear) {
      if (!reads_texels) {
        jacobian_block(c0, j, s_end, counts);
        return;
      }
    }
    prefetched_block<kBilinear>(c0, j, s_end, counts);
  }

  // Every block of the chunk [c0, c1), blocks in parallel.
  void gradients_and_taps(std::int64_t c0, std::int64_t c1) const {
    const std::int64_t blocks = (c1 - c0 + kBlock - 1) / kBlock;
    parallel_for(0, blocks, 1, [&](std::int64_t j0, std::int64_t j1) {
      for (std::int64_t j = j0; j < j1; ++j) {
        if (p.filter == Filter::Bilinear)
          tap_block<true>(c0, c1, j);
        else
          tap_block<false>(c0, c1, j);
      }
    });
  }

  // dL/d texel_t += w_t g for the chunk [c0, c1)'s taps: each band's task
  // walks its buckets block by block. sums: grad_tex (T) or the level sums (double).
  template <class A>
  void scatter(A* sums, std::int64_t c0, std::int64_t c1) const {
    const std::int64_t blocks = (c1 - c0 + kBlock - 1) / kBlock;
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
  }
};

// The level sums (acc, every level's texel gradients in double) to the
// gradients: the user's levels keep their own; the built pyramid's go down to
// level 0; then level 0's into grad_tex.
template <class T>
void add_level_sums(const TextureParams<T>& p, const WantedGrads<T>& want, int levels_used, std::int64_t acc_texels,
                    double* acc) {
  const std::int64_t C = p.channels;
  const std::int64_t base_texels = base_texel_count(p);
  if (p.user_pyramid) {
    if (want.pyramid)
      parallel_for(base_texels * C, acc_texels * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t k = lo; k < hi; ++k) want.pyramid[k - base_texels * C] += static_cast<T>(acc[k]);
      });
  } else if (levels_used > 1) {
    mip_backward(C, p.layout, acc);  // every level's gradient down to level 0
  }
  if (!want.tex) return;
  parallel_for(0, base_texels * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t k = lo; k < hi; ++k) want.tex[k] += static_cast<T>(acc[k]);
  });
}

}  // namespace

template <class T>
void texture_backward(const TextureParams<T>& p, const T* grad_out, const TextureGrads<T>& grads,
                      const T* uv_jacobian) {
  check_params(p, "texture backward");
  if (uv_jacobian && p.filter != Filter::Bilinear)
    throw ValueError("texture backward: the uv Jacobian is saved for the bilinear filter only");
  const WantedGrads<T> want = wanted_grads(p, grads);
  if (!want.texels && !want.uv && !want.lod) return;

  // Texel gradients: level 0 alone straight into grad_tex (summed in T); with
  // mip levels, every level's in double (acc), then down the pyramid.
  const int levels_used = mipmapped(p.filter) ? p.layout.count() : 1;
  const bool direct = levels_used == 1 && want.tex;
  const std::int64_t base_texels = base_texel_count(p);
  const std::int64_t acc_texels = levels_used == 1 ? base_texels : p.layout.total_texels;
  Tensor scratch;
  double* acc = nullptr;
  if (want.texels && !direct) {
    // Through the storage cache: no fresh pages in an optimization loop.
    scratch = Tensor::zeros({p.layout.total_texels * p.channels}, DType::Float64);
    acc = scratch.data<double>();
  }
  // Pooled, so an optimization loop does not fault in fresh pages every call.
  auto lease = g_bucket_pool<T>.take();
  const TapPass<T> pass(p, grad_out, uv_jacobian, want, acc_texels, *lease);

  for (std::int64_t c0 = 0; c0 < p.num_samples; c0 += pass.chunk) {
    const std::int64_t c1 = std::min(p.num_samples, c0 + pass.chunk);
    pass.gradients_and_taps(c0, c1);
    if (!want.texels) continue;
    if (direct)
      pass.scatter(want.tex, c0, c1);
    else
      pass.scatter(acc, c0, c1);
  }
  if (want.texels && !direct) add_level_sums(p, want, levels_used, acc_texels, acc);
}

#define GR_INSTANTIATE(T)                                                   \
  template void texture_forward<T>(const TextureParams<T>&, T*, T*);                                         \
  template void texture_backward<T>(const TextureParams<T>&, const T*, const TextureGrads<T>&, const T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
