// The texel sums of the mipmapped texture adjoints (raster/texture_backward.cpp,
// raster/cube_texture.cpp) without a double buffer for level 0. Levels 1..
// are summed whole, but level 0 (3/4 of all texels) only lists its taps, by
// piece of 2^shift texels and in sample order; once level 1's sums are final,
// each piece is summed in a small buffer (one per task) and handed on. Every
// texel takes its terms in the order one whole buffer gave them: the same bits.
//
// The scatters that fill the lists run one task per texel band (texel_bands);
// a piece lies in one band, so one task appends to it, in sample order.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/rasterize_setup.h"  // ScratchPool

namespace gr::raster::detail {

// Level-0 texels per piece, at most: 2^14 (384 KiB of double sums for RGB).
constexpr int kPieceShift = 14;

// Texel bands for a scatter: about one per thread, a power of two texels wide
// (band = texel >> shift), so a tap finds its band with a shift.
struct Bands {
  int shift = 0;
  std::int64_t count = 1;
};
inline Bands texel_bands(std::int64_t texels, std::int64_t threads) {
  Bands b;
  const std::int64_t want = (texels + threads - 1) / std::max<std::int64_t>(1, threads);
  while ((std::int64_t(1) << b.shift) < want) ++b.shift;
  b.count = (texels + (std::int64_t(1) << b.shift) - 1) >> b.shift;
  return b;
}

// A level-0 tap kept for later: dL/d texel += w grad_out[sample].
template <class W>
struct [[gnu::packed]] BaseTap {
  std::uint32_t offset;  // the texel within its piece
  W w;
  std::uint32_t sample;
};

template <class W>
using BaseTapLists = std::vector<std::vector<BaseTap<W>>>;
// Reused across calls, so that an optimization loop does not fault in fresh pages.
template <class W>
inline ScratchPool<BaseTapLists<W>> g_base_tap_pool;
inline ScratchPool<std::vector<double>> g_piece_sums_pool;

// Level 0's taps (texels [0, texels); samples below 2^32), by piece.
template <class W>
class BaseTapPieces {
 public:
  BaseTapPieces() : lists_(g_base_tap_pool<W>.take()) {}

  // Empty lists in pieces of 2^min(kPieceShift, band_shift) texels.
  void reset(std::int64_t texels, int band_shift) {
    texels_ = texels;
    shift_ = std::min(kPieceShift, band_shift);
    count_ = ((texels - 1) >> shift_) + 1;
    if (lists_->size() < static_cast<std::size_t>(count_)) lists_->resize(static_cast<std::size_t>(count_));
    for (std::int64_t i = 0; i < count_; ++i) (*lists_)[i].clear();
  }

  // Appends a tap to its piece (from the task of the piece's band).
  void add(std::int64_t texel, W w, std::int64_t sample) {
    (*lists_)[texel >> shift_].push_back({static_cast<std::uint32_t>(texel & ((std::int64_t(1) << shift_) - 1)), w,
                                          static_cast<std::uint32_t>(sample)});
  }

  // Pieces in parallel: each one's sums, in list order, in a pooled buffer b;
  // then done(first, last, b) for its texels [first, last), b[(t - first) C + c].
  template <class G, class Done>
  void sum_pieces(std::int64_t C, const G* grad_out, const Done& done) {
    parallel_for(0, count_, 1, [&](std::int64_t i0, std::int64_t i1) {
      auto sums = g_piece_sums_pool.take();
      for (std::int64_t i = i0; i < i1; ++i) {
        const std::int64_t first = i << shift_, last = std::min(texels_, (i + 1) << shift_);
        sums->assign(static_cast<std::size_t>((last - first) * C), 0.0);
        double* b = sums->data();
        for (const BaseTap<W>& t : (*lists_)[i]) {
          double* a = b + static_cast<std::int64_t>(t.offset) * C;
          const G* g = grad_out + static_cast<std::int64_t>(t.sample) * C;
          const double w = t.w;
          for (std::int64_t c = 0; c < C; ++c) a[c] += w * g[c];
        }
        done(first, last, static_cast<const double*>(b));
      }
    });
  }

 private:
  typename ScratchPool<BaseTapLists<W>>::Lease lists_;
  std::int64_t texels_ = 0, count_ = 0;
  int shift_ = kPieceShift;
};

}  // namespace gr::raster::detail
