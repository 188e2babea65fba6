// Tape ops over the projection kernels of raster/project.h.
#include "ops/render/project.h"

#include "autodiff/tape.h"
#include "ops/check.h"
#include "raster/project.h"

namespace gr {
namespace {

void check_rows(const Tensor& t, std::int64_t cols, const char* op, const char* name) {
  detail::check_float(t, op, name);
  detail::check_columns(t, cols, op, name);
}

}  // namespace

Tensor wdivide(const Tensor& clip) {
  check_rows(clip, 4, "wdivide", "clip");
  const std::int64_t n = clip.size(0);
  Tensor ndc = Tensor::empty({n, 3}, clip.dtype());
  dispatch_float(clip.dtype(), "wdivide", [&](auto tag) {
    using T = decltype(tag);
    raster::wdivide_forward(clip.data<T>(), n, ndc.data<T>());
  });
  if (should_record({clip})) {
    record("wdivide", {clip}, {&ndc}, [clip](AdjointContext& ctx) {
      Tensor g = Tensor::zeros(clip.shape(), clip.dtype());
      dispatch_float(clip.dtype(), "wdivide", [&](auto tag) {
        using T = decltype(tag);
        raster::wdivide_backward(clip.data<T>(), clip.size(0), ctx.grad_output().data<T>(), g.data<T>());
      });
      ctx.accumulate(0, g);
    });
  }
  return ndc;
}

Tensor viewport(const Tensor& ndc, int width, int height) {
  check_rows(ndc, 3, "viewport", "ndc");
  if (width <= 0 || height <= 0)
    throw ValueError("viewport: width and height must be positive, got " + std::to_string(width) + " x " +
                     std::to_string(height));
  const std::int64_t n = ndc.size(0);
  Tensor screen = Tensor::empty({n, 2}, ndc.dtype());
  dispatch_float(ndc.dtype(), "viewport", [&](auto tag) {
    using T = decltype(tag);
    raster::viewport_forward(ndc.data<T>(), n, width, height, screen.data<T>());
  });
  if (should_record({ndc})) {
    record("viewport", {ndc}, {&screen}, [n, width, height](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      Tensor gn = Tensor::zeros({n, 3}, g.dtype());
      dispatch_float(g.dtype(), "viewport", [&](auto tag) {
        using T = decltype(tag);
        raster::viewport_backward(n, width, height, g.data<T>(), gn.data<T>());
      });
      ctx.accumulate(0, gn);
    });
  }
  return screen;
}

}  // namespace gr
