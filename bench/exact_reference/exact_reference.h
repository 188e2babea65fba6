// The exact box-filtered image (issue 13 item 1; docs/exact_reference.md): a
// float64 reference renderer, independent of the rasterizer it grades (it
// calls none of the raster/ kernels or their adjoints). For every pixel it
// finds the exactly visible part of every triangle inside the pixel square
// (occluded parts, including those behind intersecting triangles, removed as
// polygons) and integrates the perspective-correct attribute over it.
// Conventions are the rasterizer's (docs/rasterizer.md): viewport, winding,
// depth z/w with ties to the smaller triangle index, near and far clipping.
#pragma once

#include <cstdint>
#include <vector>

#include "autodiff/base/tensor.h"
#include "raster/rasterize.h"  // raster::Cull only

namespace gr::bench {

struct ExactReferenceOptions {
  raster::Cull cull = raster::Cull::None;  // front face = counter-clockwise in NDC
  // Gauss-Legendre points per direction of the collapsed rule on each
  // triangle of a visible piece (1..32); 8 agrees with 16 to ~1e-15 on
  // pixel-sized pieces (tests/bench/test_exact_reference.cpp).
  int quadrature_order = 8;
  // Empty: every pixel. Otherwise one flag per pixel (row-major, width x
  // height): only the flagged (non-zero) pixels are computed; the others hold
  // the background with zero coverage (to time the exact image on chosen
  // pixels, e.g. those holding a visibility boundary).
  std::vector<std::uint8_t> only_pixels;
};

struct ExactImage {
  Tensor image;     // [H, W, C] float64: (integral of the visible attribute + background x uncovered area) / pixel area
  Tensor coverage;  // [H, W] float64: the visible area fraction of each pixel
};

// clip [N, 4] float64 (OpenGL clip space), triangles [M, 3] int32,
// attributes [N, C] float64, background [C] float64, width and height >= 1.
// Triangles are clipped by the near and far planes (-w <= z <= w) in clip
// space; zero-area and culled triangles are skipped. Throws ShapeError,
// DTypeError, IndexError or ValueError naming the bad input, MemoryError if
// the output does not fit the memory budget. Bit-identical for any thread count.
ExactImage exact_box_filtered(const Tensor& clip, const Tensor& triangles, const Tensor& attributes, int width,
                              int height, const Tensor& background, const ExactReferenceOptions& options = {});

}  // namespace gr::bench
