// Box-filtered mip pyramids of an H x W x C texture, and the adjoint that sends
// every level's texel gradient back to the base texture (no tape).
//
// Sizes follow the OpenGL floor rule: level l+1 is max(1, floor(H_l / 2)) x
// max(1, floor(W_l / 2)), down to 1 x 1. Along one axis of n parents and
// m = max(1, floor(n / 2)) children, child i averages the parents
// [2i, 2i + 2), except the last child (i = m - 1), which takes every parent
// from 2i to n - 1: three when n is odd (so no texel is dropped), one when
// n = 1. A child texel is the mean of its (up to 3 x 3) parent block, so a
// constant texture stays constant on every level and the adjoint hands each
// child's gradient to each of its parents divided by the block size.
#pragma once

#include <cstdint>
#include <vector>

namespace gr::raster {

struct MipLevel {
  int height = 0, width = 0;
  std::int64_t offset = 0;  // first texel of the level in an all-levels buffer (level 0 at 0)
};

struct MipLayout {
  std::vector<MipLevel> levels;  // levels[0] is the base texture
  std::int64_t total_texels = 0;  // texels of all levels together
  int count() const { return static_cast<int>(levels.size()); }
};

// Levels of a height x width texture: the full chain down to 1 x 1, or levels
// 0..max_level when max_level >= 0 (max_level 0 = the base texture only).
MipLayout mip_layout(int height, int width, int max_level = -1);

// Fills levels 1.. of `layout` into `pyramid` (total_texels - H*W texels of
// C channels, i.e. the all-levels buffer without level 0), reading `base`
// (level 0, H x W x C). Each level is the box average of the one above.
template <class T>
void mip_build(const T* base, std::int64_t channels, const MipLayout& layout, T* pyramid);

// Adjoint of mip_build on an all-levels gradient buffer (total_texels x C,
// level l at levels[l].offset * C): for l = L-1 .. 1, every parent texel of
// level l-1 receives (+=) its child's gradient divided by the child's block
// size. Afterwards level 0 of `grad` holds the full gradient w.r.t. the base
// texture. Each parent has exactly one child, so the result does not depend on
// the thread count.
void mip_backward(std::int64_t channels, const MipLayout& layout, double* grad);

// mip_backward in two steps, for a caller that sums level 0 a part at a time
// (raster/texture_backward.cpp: level 0's double sums are 3/4 of the whole
// buffer). The same sums in the same order, so the same bits:
// mip_backward_levels: levels L-1 .. 2 into their parents, on a buffer of
// levels 1.. (level l at (levels[l].offset - levels[1].offset) * C);
void mip_backward_levels(std::int64_t channels, const MipLayout& layout, double* levels);
// mip_backward_base: then, for level 0's texels [first, last) (row-major),
// level 1 (`level1`) into their sums `base` ([last - first] x C), each total
// rounded once and added to out (level 0's gradient, H x W x C):
// out[k] += T(base[k - first] + level1[child] / block size). Serial: callers
// run parts in parallel.
template <class T>
void mip_backward_base(std::int64_t channels, const MipLayout& layout, const double* level1, std::int64_t first,
                       std::int64_t last, const double* base, T* out);

}  // namespace gr::raster
