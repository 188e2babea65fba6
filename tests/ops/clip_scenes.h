// Small clip-space scenes shared by the op tests.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr::testing {

// Two overlapping triangles at different depths with w varying per vertex;
// every edge crosses the image, and pixel centres and mid-points stay well
// away from the edges at 24 x 20 (checked where a test relies on it).
inline Tensor two_triangles_clip() {
  return Tensor::from_values({-0.8, -0.7, 0.1, 1.0,   //
                              0.9, -0.6, 0.2, 1.3,    //
                              -0.1, 0.8, 0.3, 0.9,    //
                              -0.5, -0.2, -0.2, 1.1,  //
                              0.4, 0.1, 0.0, 1.2,     //
                              -0.3, 0.6, 0.1, 1.05},
                             {6, 4}, DType::Float64);
}
inline Tensor two_triangles() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3}); }

}  // namespace gr::testing
