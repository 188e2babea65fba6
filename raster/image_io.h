// Image and raw-buffer files: PNG/JPEG/BMP/TGA reading through stb_image, PNG
// writing through stb_image_write, and an atomic raw writer for G-buffer dumps.
// Images are H×W×C float32 tensors with values in [0, 1], row 0 the top row (as
// in the file and as in the screen convention of DESIGN.md). Writers never leave
// a partial file behind: they write a temporary file next to the target and
// rename it into place.
#pragma once

#include <cstddef>
#include <string>

#include "autodiff/tensor.h"

namespace gr::raster {

// Reads an 8- or 16-bit image as H×W×C float32 in [0, 1]. `channels` == 0 keeps
// the file's channel count (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA); 1–4 converts.
// Throws IOError naming the path if the file is missing, unreadable or corrupt;
// ValueError for a bad `channels`.
Tensor read_image(const std::string& path, int channels = 0);

// Writes an H×W×C (C in 1..4) or H×W (grey) float32/float64 tensor as an 8-bit
// PNG. Values are clamped to [0, 1] (NaN writes 0) and rounded to the nearest
// level. Throws ShapeError for a bad shape, DTypeError for int32, IOError if the
// file cannot be written (the target is then left untouched).
void write_png(const std::string& path, const Tensor& image);

// Writes `bytes` bytes verbatim to `path` through a temporary file and a rename,
// so readers see either the old file or the complete new one. Throws IOError.
void write_raw(const std::string& path, const void* data, std::size_t bytes);

}  // namespace gr::raster
