// Gradient accumulation used by the tape: dst += src, adopting src when dst is
// empty and adding in place when dst's storage is not shared.
#pragma once

#include "autodiff/tensor.h"

namespace gr {

void accumulate_into(Tensor& dst, const Tensor& src);

}  // namespace gr
