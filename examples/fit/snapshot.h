// Snapshot strips for watching an optimization: one row per view, each row
// target | current | absolute difference (scaled by kDifferenceGain so small
// errors show), separated by thin white gutters.
#pragma once

#include <string>
#include <vector>

#include "autodiff/base/tensor.h"

namespace fit {

constexpr double kDifferenceGain = 2.0;

// targets[v], currents[v]: [H, W, 3] images of view v -> one [V*H + gutters, 3*W + gutters, 3] image.
gr::Tensor snapshot_strip(const std::vector<gr::Tensor>& targets, const std::vector<gr::Tensor>& currents);

// Writes snapshot_strip(...) as a PNG.
void write_snapshot(const std::string& path, const std::vector<gr::Tensor>& targets,
                    const std::vector<gr::Tensor>& currents);

}  // namespace fit
