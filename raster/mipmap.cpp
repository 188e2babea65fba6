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

namespace {

// Calls f(parent texel, its child's gradient, 1 / the child's block size) for
// the texels [first, last) of level `up` (row-major), whose child level `lv`
// has its gradients at `child`.
template <class F>
void parents(std::int64_t C, const MipLevel& up, const MipLevel& lv, const double* child, std::int64_t first,
             std::int64_t last, const F& f) {
  for (std::int64_t i = first; i < last;) {
    const std::int64_t py = i / up.width;
    const int cy = child_of(int(py), lv.height);
    const int ny = block_last(cy, up.height, lv.height) - block_first(cy);
    const std::int64_t row_end = std::min(last, (py + 1) * up.width);
    for (; i < row_end; ++i) {
      const int px = static_cast<int>(i - py * up.width);
      const int cx = child_of(px, lv.width);
      const int nx = block_last(cx, up.width, lv.width) - block_first(cx);
      // d(child)/d(parent) = 1 / block size.
      const double inv = 1.0 / (nx * ny);
      f(i, child + (static_cast<std::int64_t>(cy) * lv.width + cx) * C, inv);
    }
  }
}

// Levels last .. stop + 1 into their parents (rows in parallel, each parent
// once), level l's gradients at grad + (levels[l].offset - levels[stop].offset) * C.
void push_down(std::int64_t C, const MipLayout& layout, int stop, double* grad) {
  const std::int64_t origin = layout.levels[stop].offset;
  for (int l = layout.count() - 1; l > stop; --l) {
    const MipLevel& up = layout.levels[l - 1];
    const MipLevel& lv = layout.levels[l];
    double* parent = grad + (up.offset - origin) * C;
    const double* child = grad + (lv.offset - origin) * C;
    parallel_for(0, up.height, std::max<std::int64_t>(1, 16384 / std::max(1, up.width)),
                 [&](std::int64_t y0, std::int64_t y1) {
      parents(C, up, lv, child, y0 * up.width, y1 * up.width, [&](std::int64_t i, const double* g, double inv) {
        double* p = parent + i * C;
        for (std::int64_t c = 0; c < C; ++c) p[c] += g[c] * inv;
      });
    });
  }
}

}  // namespace

void mip_backward(std::int64_t C, const MipLayout& layout, double* grad) { push_down(C, layout, 0, grad); }

void mip_backward_levels(std::int64_t C, const MipLayout& layout, double* levels) {
  if (layout.count() > 2) push_down(C, layout, 1, levels);
}

template <class T>
void mip_backward_base(std::int64_t C, const MipLayout& layout, const double* level1, std::int64_t first,
                       std::int64_t last, const double* base, T* out) {
  if (layout.count() < 2) return;
  // As mip_backward's last step, level 0's sum plus the child's share, then rounded once.
  parents(C, layout.levels[0], layout.levels[1], level1, first, last, [&](std::int64_t i, const double* g, double inv) {
    const double* b = base + (i - first) * C;
    for (std::int64_t c = 0; c < C; ++c) out[i * C + c] += static_cast<T>(b[c] + g[c] * inv);
  });
}

template void mip_build<float>(const float*, std::int64_t, const MipLayout&, float*);
template void mip_build<double>(const double*, std::int64_t, const MipLayout&, double*);
template void mip_backward_base<float>(std::int64_t, const MipLayout&, const double*, std::int64_t, std::int64_t,
                                       const double*, float*);
template void mip_backward_base<double>(std::int64_t, const MipLayout&, const double*, std::int64_t, std::int64_t,
                                        const double*, double*);

}  // namespace gr::raster
