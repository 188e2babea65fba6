// downsample_box: forward and adjoint side by side.
#include "ops/render/resample.h"

#include <algorithm>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/tensor/broadcast.h"

namespace gr {
namespace {

// out[y, x, :] = sum of the s x s block / s^2, rows y in [y0, y1).
template <class T>
void downsample_rows(const T* in, int s, std::int64_t w, std::int64_t c, std::int64_t y0, std::int64_t y1, T* out) {
  using Acc = double;
  const double scale = 1.0 / (double(s) * s);
  const std::int64_t in_row = std::int64_t(s) * w * c;  // one input row
  std::vector<Acc> acc(static_cast<std::size_t>(w * c));
  for (std::int64_t y = y0; y < y1; ++y) {
    std::fill(acc.begin(), acc.end(), Acc(0));
    for (int i = 0; i < s; ++i) {
      const T* row = in + (y * s + i) * in_row;
      for (std::int64_t x = 0; x < w; ++x)
        for (int j = 0; j < s; ++j)
          for (std::int64_t k = 0; k < c; ++k) acc[x * c + k] += row[(x * s + j) * c + k];
    }
    T* o = out + y * w * c;
    for (std::int64_t e = 0; e < w * c; ++e) o[e] = static_cast<T>(acc[e] * scale);
  }
}

// grad_in[Y, X, :] = g[Y / s, X / s, :] / s^2, input rows Y in [y0, y1).
template <class T>
void upsample_rows(const T* g, int s, std::int64_t w, std::int64_t c, std::int64_t y0, std::int64_t y1, T* grad_in) {
  const T scale = static_cast<T>(1.0 / (double(s) * s));
  const std::int64_t in_w = std::int64_t(s) * w;
  for (std::int64_t y = y0; y < y1; ++y) {
    const T* gr = g + (y / s) * w * c;
    T* o = grad_in + y * in_w * c;
    for (std::int64_t x = 0; x < in_w; ++x)
      for (std::int64_t k = 0; k < c; ++k) o[x * c + k] = gr[(x / s) * c + k] * scale;
  }
}

// Rows per parallel chunk: about kElementwiseGrain elements.
std::int64_t row_grain(std::int64_t row_elements) {
  return std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, row_elements));
}

}  // namespace

Tensor downsample_box(const Tensor& image, int factor) {
  detail::check_float(image, "downsample_box", "image");
  if (factor < 1) throw ValueError("downsample_box: argument 'factor' must be >= 1, got " + std::to_string(factor));
  if (image.rank() != 3 || image.size(0) % factor != 0 || image.size(1) % factor != 0)
    throw ShapeError("downsample_box: argument 'image' must have shape [s H, s W, C] with s = factor = " +
                     std::to_string(factor) + ", got " + image.describe());
  const int s = factor;
  const std::int64_t h = image.size(0) / s, w = image.size(1) / s, c = image.size(2);
  Tensor out = Tensor::empty({h, w, c}, image.dtype());
  dispatch_float(image.dtype(), "downsample_box", [&](auto tag) {
    using T = decltype(tag);
    const T* in = image.data<T>();
    T* o = out.data<T>();
    parallel_for(0, h, row_grain(std::int64_t(s) * s * w * c),
                 [&](std::int64_t y0, std::int64_t y1) { downsample_rows(in, s, w, c, y0, y1, o); });
  });
  if (should_record({image})) {
    record("downsample_box", {image}, {&out}, [s, h, w, c](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      Tensor gi = Tensor::empty({s * h, s * w, c}, g.dtype());
      dispatch_float(g.dtype(), "downsample_box", [&](auto tag) {
        using T = decltype(tag);
        const T* gd = g.data<T>();
        T* o = gi.data<T>();
        parallel_for(0, s * h, row_grain(std::int64_t(s) * w * c),
                     [&](std::int64_t y0, std::int64_t y1) { upsample_rows(gd, s, w, c, y0, y1, o); });
      });
      ctx.accumulate(0, gi);
    });
  }
  return out;
}

}  // namespace gr
