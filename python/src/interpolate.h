// interpolate in nvdiffrast's layout: attributes blended with a G-buffer's
// barycentrics, optionally with image-space derivatives of some channels.
#pragma once

#include <vector>

#include "python/src/common.h"

namespace gr::python {

struct InterpolateArgs {
  bool f64 = false;
  Address attr = 0;               // [attr_images, N, C] (attr_images 1 = broadcast)
  std::int64_t attr_images = 1;
  std::int64_t vertices = 0, channels = 0;
  Address tri = 0;                // [M, 3] int32
  std::int64_t triangles = 0;
  Address rast = 0;               // [images, H, W, 4]
  Address rast_db = 0;            // same shape or 0
  std::int64_t images = 0, height = 0, width = 0;
  std::vector<std::int32_t> diff;  // channels to differentiate
};

// out: [images, H, W, C]; out_da: [images, H, W, 2 diff] or 0.
void interpolate_forward(const InterpolateArgs& a, Address out, Address out_da, int threads);
// Accumulates into grad_attr (attr's shape, zeroed; 0 = not needed),
// grad_rast and grad_db (zeroed, or 0). grad_da may be 0.
void interpolate_backward(const InterpolateArgs& a, Address grad_out, Address grad_da, Address grad_attr,
                          Address grad_rast, Address grad_db, int threads);

}  // namespace gr::python
