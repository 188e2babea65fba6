// Resampling an image by whole-pixel blocks, as an op on the tape.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

// Box-filter downsampling, the resolve step of supersampling: image
// [s H, s W, C] (float32/float64) -> [H, W, C] with each output pixel the mean
// of its s x s block,
//   out[y, x, c] = 1/s^2 sum_{i, j < s} image[s y + i, s x + j, c],
// and dL/dimage[Y, X, c] = g[Y / s, X / s, c] / s^2 (integer division).
// float32 blocks are summed in double; every output pixel is summed in the same
// order for any thread count. factor = 1 returns a copy. Throws ShapeError
// unless image has rank 3 with both image axes divisible by factor, and
// ValueError for factor < 1.
Tensor downsample_box(const Tensor& image, int factor);

}  // namespace gr
