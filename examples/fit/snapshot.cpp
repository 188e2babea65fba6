// snapshot_strip: the images copied into one strip in a single pass (no
// temporaries: it runs beside the loop, on the snapshot writer's thread).
#include "examples/fit/snapshot.h"

#include <algorithm>
#include <cmath>

#include "autodiff/base/error.h"
#include "raster/io/image_io.h"

namespace fit {

using namespace gr;

namespace {

constexpr int kGutter = 2;

// Copies `rows` x `width` pixels (3 floats each) of `pixel(y, x, c)` to `out` at column `x0` of a strip `stride` wide.
template <class Pixel>
void put_panel(float* out, std::int64_t stride, std::int64_t x0, std::int64_t rows, std::int64_t width,
               Pixel pixel) {
  for (std::int64_t y = 0; y < rows; ++y)
    for (std::int64_t x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) out[(y * stride + x0 + x) * 3 + c] = pixel((y * width + x) * 3 + c);
}

}  // namespace

Tensor snapshot_strip(const std::vector<Tensor>& targets, const std::vector<Tensor>& currents) {
  if (targets.empty() || targets.size() != currents.size())
    throw ValueError("snapshot_strip: need one current image per target image");
  const std::int64_t h = targets[0].size(0), w = targets[0].size(1);
  for (std::size_t v = 0; v < targets.size(); ++v)
    for (const Tensor* image : {&targets[v], &currents[v]})
      if (image->dtype() != DType::Float32 || image->rank() != 3 || image->size(0) != h || image->size(1) != w ||
          image->size(2) != 3)
        throw ShapeError("snapshot_strip: every image must be float32 [" + std::to_string(h) + ", " +
                         std::to_string(w) + ", 3] like the first target, got " + image->describe());
  const auto views = static_cast<std::int64_t>(targets.size());
  const std::int64_t stride = 3 * w + 2 * kGutter;
  Tensor strip = Tensor::full({views * h + (views - 1) * kGutter, stride, 3}, 1.0);  // white gutters
  const auto gain = static_cast<float>(kDifferenceGain);
  for (std::int64_t v = 0; v < views; ++v) {
    const float* target = targets[v].data<float>();
    const float* current = currents[v].data<float>();
    float* row = strip.data<float>() + v * (h + kGutter) * stride * 3;
    put_panel(row, stride, 0, h, w, [&](std::int64_t i) { return target[i]; });
    put_panel(row, stride, w + kGutter, h, w, [&](std::int64_t i) { return current[i]; });
    put_panel(row, stride, 2 * (w + kGutter), h, w, [&](std::int64_t i) {
      return std::clamp(std::fabs(current[i] - target[i]) * gain, 0.0f, 1.0f);
    });
  }
  return strip;
}

void write_snapshot(const std::string& path, const std::vector<Tensor>& targets, const std::vector<Tensor>& currents) {
  raster::write_png(path, snapshot_strip(targets, currents));
}

}  // namespace fit
