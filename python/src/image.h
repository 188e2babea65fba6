// PNG output for the Python package (gradraster.write_png), through
// raster/io/image_io's atomic writer.
#pragma once

#include <string>

#include "python/src/common.h"

namespace gr::python {

// image: [height, width, channels] float32 (1-4 channels), values in [0, 1].
void write_png(const std::string& path, const pybind11::object& image);

}  // namespace gr::python
