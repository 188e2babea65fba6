// Mip pyramid forward (box average of parent blocks) and adjoint (each parent
// gathers from its single child), both parallel over rows of the level written.
#include "raster/mipmap.h"

#include <algorithm>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"

namespace gr::raster {
namespace {

// Parents [first, last) of child i along an axis of n parents and m children.
inline int block_first(int i) { return 2 * i; }
inline int block_last(int i, int n, int m) { return i == m - 1 ? n : 2 * i + 2; }
// The child of parent p.
inline int child_of(int p, int m) { return std::min(p / 2, m - 1); }

}  // namespace

MipLayout mip_layout(int height, int width, int max_level) {
  if (height < 1 || width < 1)
    throw ShapeError("mip_layout: texture size " + std::to_string(height) + " x " + std::to_string(width) +
                     " must be at least 1 x 1");
  MipLayout layout;
  int h = height, w = width;
  std::int64_t offset = 0;
  for (int l = 0;; ++l) {
    layout.levels.push_back({h, w, offset});
    offset += static_cast<std::int64_t>(h) * w;
    if ((h == 1 && w == 1) || (max_level >= 0 && l >= max_level)) break;
    h = std::max(1, h / 2);
    w = std::max(1, w / 2);
  }
  layout.total_texels = offset;
  return layout;
}

template <class T>
void mip_build(const T* base, std::int64_t C, const MipLayout& layout, T* pyramid) {
  if (layout.count() < 2) return;
  const std::int64_t base_texels = static_cast<std::int64_t>(layout.levels[0].height) * layout.levels[0].width;
  for (int l = 1; l < layout.count(); ++l) {
    const MipLevel& up = layout.levels[l - 1];
    const MipLevel& lv = layout.levels[l];
    const T* src = l == 1 ? base : pyramid + (up.offset - base_texels) * C;
    T* dst = pyramid + (lv.offset - base_texels) * C;
    parallel_for(0, lv.height, std::max<std::int64_t>(1, 16384 / std::max(1, lv.width)),
                 [&](std::int64_t y0, std::int64_t y1) {
      std::vector<double> acc(static_cast<std::size_t>(C));
      for (std::int64_t y = y0; y < y1; ++y) {
        const int py0 = block_first(int(y)), py1 = block_last(int(y), up.height, lv.height);
        for (int x = 0; x < lv.width; ++x) {
          const int px0 = block_first(x), px1 = block_last(x, up.width, lv.width);
          // Mean of the parent block, summed in double.
          std::fill(acc.begin(), acc.end(), 0.0);
          for (int py = py0; py < py1; ++py)
            for (int px = px0; px < px1; ++px) {
              const T* s = src + (static_cast<std::int64_t>(py) * up.width + px) * C;
              for (std::int64_t c = 0; c < C; ++c) acc[c] += s[c];
            }
          const double inv = 1.0 / ((py1 - py0) * (px1 - px0));
          T* d = dst + (y * lv.width + x) * C;
          for (std::int64_t c = 0; c < C; ++c) d[c] = static_cast<T>(acc[c] * inv);
        }
      }
    });
  }
}

void mip_backward(std::int64_t C, const MipLayout& layout, double* grad) {
  for (int l = layout.count() - 1; l >= 1; --l) {
    const MipLevel& up = layout.levels[l - 1];
    const MipLevel& lv = layout.levels[l];
    const double* child = grad + lv.offset * C;
    double* parent = grad + up.offset * C;
    parallel_for(0, up.height, std::max<std::int64_t>(1, 16384 / std::max(1, up.width)),
                 [&](std::int64_t y0, std::int64_t y1) {
      for (std::int64_t py = y0; py < y1; ++py) {
        const int cy = child_of(int(py), lv.height);
        const int ny = block_last(cy, up.height, lv.height) - block_first(cy);
        for (int px = 0; px < up.width; ++px) {
          const int cx = child_of(px, lv.width);
          const int nx = block_last(cx, up.width, lv.width) - block_first(cx);
          // d(child)/d(parent) = 1 / block size.
          const double inv = 1.0 / (nx * ny);
          const double* g = child + (static_cast<std::int64_t>(cy) * lv.width + cx) * C;
          double* p = parent + (py * up.width + px) * C;
          for (std::int64_t c = 0; c < C; ++c) p[c] += g[c] * inv;
        }
      }
    });
  }
}

template void mip_build<float>(const float*, std::int64_t, const MipLayout&, float*);
template void mip_build<double>(const double*, std::int64_t, const MipLayout&, double*);

}  // namespace gr::raster
