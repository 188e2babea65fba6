// sRGB transfer functions (IEC 61966-2-1): shading works in linear radiance;
// textures authored in sRGB are decoded with srgb_to_linear before shading and
// results are encoded with linear_to_srgb for display.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr::shading {

// Elementwise sRGB decoding, any shape, float32/float64:
//   x <= 0.04045 ? x / 12.92 : ((x + 0.055) / 1.055)^2.4.
// No clamp: x > 1 follows the power branch, x < 0 the linear one.
// dL/dx = g / 12.92 on the linear branch (the threshold included),
// g (2.4 / 1.055) ((x + 0.055) / 1.055)^1.4 on the power branch.
Tensor srgb_to_linear(const Tensor& x);

// Elementwise sRGB encoding, the inverse:
//   x <= 0.0031308 ? 12.92 x : 1.055 x^(1/2.4) - 0.055.
// dL/dx = 12.92 g on the linear branch (the threshold included),
// g (1.055 / 2.4) x^(1/2.4 - 1) on the power branch.
Tensor linear_to_srgb(const Tensor& x);

}  // namespace gr::shading
