// sRGB transfer functions as compositions of tensor ops (formulas in colour.h).
// Each branch is a where(); the power branch's base is held at the threshold
// where that branch is not taken, so no NaN (a negative base to a fractional
// power) appears in it, not even under a zero gradient.
#include "ops/shading/colour.h"

#include "ops/check.h"
#include "ops/tensor/elementwise.h"

namespace gr::shading {

Tensor srgb_to_linear(const Tensor& x) {
  gr::detail::check_float(x, "shading::srgb_to_linear", "x");
  constexpr double threshold = 0.04045;
  const Tensor linear = x <= threshold;  // mask, no gradient
  const Tensor curve = pow((maximum(x, threshold) + 0.055) / 1.055, 2.4);
  return where(linear, x / 12.92, curve);
}

Tensor linear_to_srgb(const Tensor& x) {
  gr::detail::check_float(x, "shading::linear_to_srgb", "x");
  constexpr double threshold = 0.0031308;
  const Tensor linear = x <= threshold;  // mask, no gradient
  const Tensor curve = 1.055 * pow(maximum(x, threshold), 1.0 / 2.4) - 0.055;
  return where(linear, 12.92 * x, curve);
}

}  // namespace gr::shading
