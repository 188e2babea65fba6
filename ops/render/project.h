// The perspective divide and the viewport transform as ops on the tape.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

// clip [N, 4] -> ndc [N, 3] = (x/w, y/w, z/w).
// dL/dx_c = dL/dx_ndc / w (y, z alike), dL/dw = -sum_c dL/dc_ndc * c / w^2.
// Throws ValueError if a vertex has w == 0 (clip first; rasterize does).
Tensor wdivide(const Tensor& clip);
// ndc [N, 3] -> screen [N, 2] = (W/2 (1 + x_ndc), H/2 (1 - y_ndc)); row 0 is the top.
// dL/dx_ndc = W/2 dL/dxs, dL/dy_ndc = -H/2 dL/dys.
Tensor viewport(const Tensor& ndc, int width, int height);

}  // namespace gr
