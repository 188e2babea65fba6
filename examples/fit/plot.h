// A loss curve drawn straight into an image tensor, no plotting library:
// white canvas, axes, a grid line and label at every power of ten (log-scale
// y axis), iteration labels on the x axis, and the loss as a polyline.
#pragma once

#include <vector>

#include "autodiff/base/tensor.h"

namespace fit {

// [height, width, 3] float32 image of losses[i] against iteration i.
// Non-positive or non-finite losses are left out of the polyline.
gr::Tensor plot_loss_curve(const std::vector<double>& losses, int width = 640, int height = 400);

}  // namespace fit
