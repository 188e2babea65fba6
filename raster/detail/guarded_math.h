// Guarded arithmetic shared by the adjoint kernels, so degenerate input
// (slivers, w -> 0, coincident vertices) yields large but finite gradients
// instead of Inf or NaN.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace gr::raster::detail {

// 1 / x, kept finite for |x| -> 0 (sign preserved; +0 counts as positive).
inline double safe_inv(double x) { return 1.0 / (x + std::copysign(1e-30, x)); }

// Converts a double to T, mapping NaN to 0 and clamping to T's finite range.
template <class T>
T finite_cast(double x) {
  const double big = static_cast<double>(std::numeric_limits<T>::max());
  if (!(x == x)) return T(0);
  return static_cast<T>(std::clamp(x, -big, big));
}

}  // namespace gr::raster::detail
