// Image and raw-buffer files: PNG, JPEG, BMP and TGA reading (stb_image built
// for these four formats only, image_decoder.h), PNG writing
// (raster/io/png_encoder.h), and an atomic raw writer for G-buffer dumps.
// Images are H×W×C float32 tensors with values in [0, 1], row 0 the top row (as
// in the file and as in the screen convention of DESIGN.md). Files are read and
// written through raster/io/files.h: inputs must be regular files of bounded size,
// and writers never leave a partial file behind nor replace anything but a
// regular file (a temporary next to the target is renamed into place).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr::raster {

// The largest image side read_image decodes (the texture op's limit too).
constexpr int kMaxImageSide = 32768;
// The most decoded sample bytes (width x height x channels x bytes per sample)
// read_image decodes: stb_image's own limit for PNG.
constexpr std::size_t kMaxDecodedImageBytes = std::size_t(1) << 30;

// Reads an 8- or 16-bit PNG, JPEG, BMP or TGA image as H×W×C float32 in [0, 1].
// `channels` == 0 keeps the file's channel count (1 grey, 2 grey+alpha, 3 RGB,
// 4 RGBA); 1–4 converts. The format is told by the file's first bytes; other
// formats (Radiance HDR, GIF, PNM, PSD, ...) are refused, naming the format
// found, before any decoder runs. The size in the header is checked (sides up
// to kMaxImageSide, at most kMaxDecodedImageBytes decoded, the memory budget)
// before anything is decoded, and the decoder's own allocations are counted
// against what the budget leaves. Throws IOError naming the path if the file
// is missing, not a regular file, unreadable, of another format, corrupt or
// too large; MemoryError if decoding it would exceed the memory budget;
// ValueError for a bad `channels`.
Tensor read_image(const std::string& path, int channels = 0);

// read_image on a file's bytes held in memory, with the same rules and errors;
// `name` stands in for the path in messages.
Tensor read_image_from_memory(const std::string& bytes, const std::string& name, int channels = 0);

// Writes an H×W×C (C in 1..4) or H×W (grey) float32/float64 tensor as an 8-bit
// PNG. Values are clamped to [0, 1] (NaN writes 0) and rounded to the nearest
// level. Throws ShapeError for a bad shape, DTypeError for int32, IOError if the
// file cannot be written (the target is then left untouched).
void write_png(const std::string& path, const Tensor& image);

// The PNG bytes write_png writes, for callers that stage several outputs in
// one OutputSet (raster/io/files.h). `what` starts the error messages.
std::vector<unsigned char> encode_png(const Tensor& image, const std::string& what);

// Writes `bytes` bytes verbatim to `path` through a temporary file and a rename,
// so readers see either the old file or the complete new one. Throws IOError,
// also if `path` exists and is not a regular file (symlink, FIFO, device).
void write_raw(const std::string& path, const void* data, std::size_t bytes);

}  // namespace gr::raster
