// Picking one channel of the last axis without a hand-written slice.
#pragma once

#include <cstdint>

#include "autodiff/base/tensor.h"

namespace gr {

// Channel k of the last axis, kept as an axis of extent 1: [..., C] -> [..., 1],
// so it broadcasts against [..., C] the way dot() and length() results do
// (rgb * channel(rgba, 3) weights colour by alpha). k in [-C, C), negative
// counting from the end; IndexError otherwise, ShapeError for a rank-0
// tensor. Any dtype. dL/da = g at channel k, 0 elsewhere.
Tensor channel(const Tensor& a, std::int64_t k);

}  // namespace gr
