// snapshot_strip: concatenates images with tensor ops (no gradient recorded).
#include "examples/fit/snapshot.h"

#include "autodiff/error.h"
#include "autodiff/tape.h"
#include "ops/ops.h"
#include "raster/image_io.h"

namespace fit {

using namespace gr;

Tensor snapshot_strip(const std::vector<Tensor>& targets, const std::vector<Tensor>& currents) {
  if (targets.empty() || targets.size() != currents.size())
    throw ValueError("snapshot_strip: need one current image per target image");
  NoGradGuard no_grad;
  const std::int64_t h = targets[0].size(0), w = targets[0].size(1);
  const int gutter = 2;
  const Tensor vertical_gutter = Tensor::ones({h, gutter, 3});
  const Tensor horizontal_gutter = Tensor::ones({gutter, 3 * w + 2 * gutter, 3});
  std::vector<Tensor> rows;
  for (std::size_t v = 0; v < targets.size(); ++v) {
    const Tensor difference = clamp(abs(currents[v] - targets[v]) * kDifferenceGain, 0.0, 1.0);
    if (v > 0) rows.push_back(horizontal_gutter);
    rows.push_back(concat({targets[v], vertical_gutter, currents[v], vertical_gutter, difference}, 1));
  }
  return concat(rows, 0);
}

void write_snapshot(const std::string& path, const std::vector<Tensor>& targets, const std::vector<Tensor>& currents) {
  raster::write_png(path, snapshot_strip(targets, currents));
}

}  // namespace fit
