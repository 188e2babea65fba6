#include "python/src/image.h"

#include <algorithm>

#include "autodiff/tensor.h"
#include "raster/image_io.h"

namespace gr::python {

void write_png(const std::string& path, Address image, std::int64_t height, std::int64_t width, std::int64_t channels) {
  Tensor t = Tensor::empty({height, width, channels}, DType::Float32);
  const float* src = at<const float>(image);
  std::copy(src, src + height * width * channels, t.data<float>());
  pybind11::gil_scoped_release release;
  raster::write_png(path, t);
}

}  // namespace gr::python
