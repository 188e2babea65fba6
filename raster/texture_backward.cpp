// Texture sampling's adjoint (raster/texture.h): the samples' uv and LOD
// gradients in parallel, and their taps filed by texel band, so that one task
// per band adds each texel's gradients in sample order (the result does not
// depend on the thread count).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/base/tensor.h"
#include "raster/detail/rasterize_setup.h"  // detail::ScratchPool
#include "raster/detail/texel_pieces.h"
#include "raster/texture.h"
#include "raster/detail/texture_taps.h"

namespace gr::raster {
using namespace texture_taps;
namespace {

using detail::Bands;
using detail::BaseTapPieces;
using detail::texel_bands;

constexpr int kScatterAhead = 32;  // taps ahead whose texel gradients the scatter prefetches

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

  // visit(e, n, first): each band's task walks its buckets block by block;
  // a bucket's taps are e[0, n), tap q on sample first + e[q].sample.
  template <class Visit>
  void for_each_bucket(std::int64_t c0, std::int64_t c1, Visit visit) const {
    const std::int64_t blocks = (c1 - c0 + kBlock - 1) / kBlock;
    parallel_for(0, bands.count, 1, [&](std::int64_t b0, std::int64_t b1) {
      for (std::int64_t b = b0; b < b1; ++b)
        for (std::int64_t j = 0; j < blocks; ++j)
          visit(&entries[(j * bands.count + b) * bucket_size], count[j * bands.count + b], c0 + j * kBlock);
    });
  }

  // As scatter, with mip levels: taps on levels 1.. added to `levels` (level
  // 1's first texel at 0); taps on level 0 appended, in the same order, to
  // the list of their piece (pieces null: dropped). A piece lies in one band
  // (BaseTapPieces::reset), so one task fills it.
  void scatter_levels(double* levels, BaseTapPieces<T>* pieces, std::int64_t c0, std::int64_t c1) const {
    for_each_bucket(c0, c1, [&](const TapEntry<T>* e, std::int32_t n, std::int64_t first) {
      for (std::int32_t q = 0; q < n; ++q) {
        const std::int64_t s = first + e[q].sample;
        const std::int64_t texel = e[q].texel;
        if (texel < base_texels) {
          if (pieces) pieces->add(texel, e[q].w, s);
          continue;
        }
        if (q + kScatterAhead < n && e[q + kScatterAhead].texel >= base_texels)
          __builtin_prefetch(levels + (e[q + kScatterAhead].texel - base_texels) * C, 1);
        double* a = levels + (texel - base_texels) * C;
        const T* g = grad_out + s * C;
        const double w = e[q].w;
        for (std::int64_t c = 0; c < C; ++c) a[c] += w * g[c];
      }
    });
  }

  // dL/d texel_t += w_t g for the chunk [c0, c1)'s taps. sums: grad_tex (T)
  // or the level sums (double).
  template <class A>
  void scatter(A* sums, std::int64_t c0, std::int64_t c1) const {
    for_each_bucket(c0, c1, [&](const TapEntry<T>* e, std::int32_t n, std::int64_t first) {
      for (std::int32_t q = 0; q < n; ++q) {
        if (q + kScatterAhead < n) __builtin_prefetch(sums + e[q + kScatterAhead].texel * C, 1);
        auto* a = sums + e[q].texel * C;
        const T* g = grad_out + (first + e[q].sample) * C;
        const double w = e[q].w;
        for (std::int64_t c = 0; c < C; ++c) a[c] += w * g[c];
      }
    });
  }
};

// Where the texel gradients are summed: level 0 alone straight into grad_tex
// (in T, as the tape sums); with mip levels, in double, rounded once when
// finish() hands them on. Levels 1.. are summed in one buffer as the taps come
// (through the storage cache: no fresh pages in an optimization loop). Level
// 0's sums, 3/4 of all texels, are not kept whole: its taps are listed by
// piece of 2^14 texels (raster/detail/texel_pieces.h), in sample order, and
// once level 1's sums are final each piece is summed in a small buffer, level
// 1's share added (mip_backward_base) and the total rounded into grad_tex.
// Every texel's sum takes its terms in the order one whole buffer did, so the
// bits are the same, and a 2048 x 2048 RGB texture's first call maps 32 MiB of
// sums, not 128.
template <class T>
struct TexelSums {
  const TextureParams<T>& p;
  const WantedGrads<T>& want;
  int levels_used;          // 1, or every level of the layout (mipmapped filters)
  bool direct;              // level 0 alone, into want.tex
  std::int64_t texels;      // texels whose gradients are summed (all levels' when mipmapped)
  std::int64_t base_texels;
  Tensor scratch;
  double* levels = nullptr;  // levels 1..'s sums, when not direct
  BaseTapPieces<T> pieces;    // level 0's taps, when listed
  bool list_base = false;     // mipmapped and grad_tex wanted

  TexelSums(const TextureParams<T>& params, const WantedGrads<T>& w) : p(params), want(w) {
    levels_used = mipmapped(p.filter) ? p.layout.count() : 1;
    direct = levels_used == 1 && want.tex;
    base_texels = base_texel_count(p);
    texels = levels_used == 1 ? base_texels : p.layout.total_texels;
    if (!want.texels || direct) return;
    scratch = Tensor::zeros({(p.layout.total_texels - base_texels) * p.channels}, DType::Float64);
    levels = scratch.data<double>();
  }

  // Sizes the level-0 pieces to the pass's bands (each piece in one band).
  void prepare(const TapPass<T>& pass) {
    if (!want.texels || direct || !want.tex) return;
    pieces.reset(base_texels, pass.bands.shift);
    list_base = true;
  }

  // The chunk [c0, c1)'s taps added (or listed).
  void scatter(const TapPass<T>& pass, std::int64_t c0, std::int64_t c1) {
    if (!want.texels) return;
    if (direct)
      pass.scatter(want.tex, c0, c1);
    else
      pass.scatter_levels(levels, list_base ? &pieces : nullptr, c0, c1);
  }

  // The level sums to the gradients: the user's levels keep their own; the
  // built pyramid's go down to level 1 (mip_backward_levels). Then level 0,
  // a piece at a time: its taps summed, level 1's share added unless the
  // levels are the user's, rounded into grad_tex.
  void finish(const T* grad_out) {
    if (!want.texels || direct) return;
    const std::int64_t C = p.channels;
    if (p.user_pyramid) {
      if (want.pyramid)
        parallel_for(0, (texels - base_texels) * C, kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
          for (std::int64_t k = lo; k < hi; ++k) want.pyramid[k] += static_cast<T>(levels[k]);
        });
    } else {
      mip_backward_levels(C, p.layout, levels);
    }
    if (!want.tex) return;
    pieces.sum_pieces(C, grad_out, [&](std::int64_t first, std::int64_t last, const double* b) {
      if (p.user_pyramid) {
        for (std::int64_t k = first * C; k < last * C; ++k) want.tex[k] += static_cast<T>(b[k - first * C]);
      } else {
        mip_backward_base(C, p.layout, levels, first, last, b, want.tex);
      }
    });
  }
};

template <class T>
void check_backward(const TextureParams<T>& p, const T* uv_jacobian) {
  check_params(p, "texture backward");
  if (uv_jacobian && p.filter != Filter::Bilinear)
    throw ValueError("texture backward: the uv Jacobian is saved for the bilinear filter only");
}

}  // namespace

template <class T>
void texture_backward(const TextureParams<T>& p, const T* grad_out, const TextureGrads<T>& grads,
                      const T* uv_jacobian) {
  check_backward(p, uv_jacobian);
  const WantedGrads<T> want = wanted_grads(p, grads);
  if (!want.texels && !want.uv && !want.lod) return;
  TexelSums<T> sums(p, want);
  // Pooled, so an optimization loop does not fault in fresh pages every call.
  auto lease = g_bucket_pool<T>.take();
  const TapPass<T> pass(p, grad_out, uv_jacobian, want, sums.texels, *lease);
  sums.prepare(pass);
  for (std::int64_t c0 = 0; c0 < p.num_samples; c0 += pass.chunk) {
    const std::int64_t c1 = std::min(p.num_samples, c0 + pass.chunk);
    pass.gradients_and_taps(c0, c1);
    sums.scatter(pass, c0, c1);
  }
  sums.finish(grad_out);
}

#define GR_INSTANTIATE(T) \
  template void texture_backward<T>(const TextureParams<T>&, const T*, const TextureGrads<T>&, const T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
