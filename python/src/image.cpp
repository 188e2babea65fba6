#include "python/src/image.h"

#include <algorithm>

#include "autodiff/base/error.h"
#include "autodiff/base/tensor.h"
#include "raster/io/image_io.h"

namespace gr::python {

void write_png(const std::string& path, const pybind11::object& image_) {
  const Array image(image_, "write_png", "image");
  image.elem_in({Elem::F32}).rank({3});
  if (image.size(0) < 1 || image.size(1) < 1 || image.size(2) < 1 || image.size(2) > 4)
    throw ValueError("write_png: 'image' must be [H, W, C] with C in 1..4, got shape " +
                     shape_string(image.shape()));
  Tensor t = Tensor::empty({image.size(0), image.size(1), image.size(2)}, DType::Float32);
  const float* src = image.in<float>();
  std::copy(src, src + image.numel(), t.data<float>());
  pybind11::gil_scoped_release release;
  raster::write_png(path, t);
}

}  // namespace gr::python
