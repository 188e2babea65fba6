// Image and raw-buffer files: PNG/JPEG/BMP/TGA reading through stb_image, PNG
// writing through stb_image_write, and an atomic raw writer for G-buffer dumps.
// Images are H×W×C float32 tensors with values in [0, 1], row 0 the top row (as
// in the file and as in the screen convention of DESIGN.md). Files are read and
// written through raster/files.h: inputs must be regular files of bounded size,
// and writers never leave a partial file behind nor replace anything but a
// regular file (a temporary next to the target is renamed into place).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "autodiff/tensor.h"

namespace gr::raster {

// The largest image side read_image decodes (the texture op's limit too).
constexpr int kMaxImageSide = 32768;

// Reads an 8- or 16-bit image as H×W×C float32 in [0, 1]. `channels` == 0 keeps
// the file's channel count (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA); 1–4 converts.
// The size in the header is checked (sides up to kMaxImageSide, the memory
// budget) before anything is decoded. Throws IOError naming the path if the
// file is missing, not a regular file, unreadable, corrupt or too large;
// MemoryError if decoding it would exceed the memory budget; ValueError for a
// bad `channels`.
Tensor read_image(const std::string& path, int channels = 0);

// Writes an H×W×C (C in 1..4) or H×W (grey) float32/float64 tensor as an 8-bit
// PNG. Values are clamped to [0, 1] (NaN writes 0) and rounded to the nearest
// level. Throws ShapeError for a bad shape, DTypeError for int32, IOError if the
// file cannot be written (the target is then left untouched).
void write_png(const std::string& path, const Tensor& image);

// The PNG bytes write_png writes, for callers that stage several outputs in
// one OutputSet (raster/files.h). `what` starts the error messages.
std::vector<unsigned char> encode_png(const Tensor& image, const std::string& what);

// Writes `bytes` bytes verbatim to `path` through a temporary file and a rename,
// so readers see either the old file or the complete new one. Throws IOError,
// also if `path` exists and is not a regular file (symlink, FIFO, device).
void write_raw(const std::string& path, const void* data, std::size_t bytes);

}  // namespace gr::raster
