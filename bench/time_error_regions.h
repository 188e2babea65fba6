// Which pixels of a time_error scene hold a visibility boundary, by kind
// (docs/time_error.md, "Why the error stalls" and "What 1% at 1x would cost"):
// the regions time_error_plateau splits the gradient error by, and the pixels
// bench_box_filter times the exact image on.
#pragma once

#include <cstdint>
#include <vector>

#include "bench/time_error_scene.h"

namespace gr::bench {

// Kinds in decreasing precedence where a pixel holds several: background
// boundary, depth jump, object change; interior otherwise.
enum PixelRegion : int {
  kInterior = 0,
  kBackgroundBoundary = 1,  // covered and uncovered subsamples meet in the pixel
  kDepthJump = 2,           // the view distance jumps by > 0.1 units between neighbouring subsamples (occlusion)
  kObjectChange = 3,        // another object continues without a depth jump (an intersection curve)
  kNumPixelRegions = 4,
};

// One region per pixel of the scene (row-major, width x height), found on an
// 8x G-buffer of the scene at the given points: a pixel gets the kind of any
// pair of neighbouring subsamples in it (or straddling its border) that differ.
std::vector<int> pixel_regions(const TimeErrorScene& scene, const Tensor& points);

// 1 for the pixels of `regions` that are not interior, 0 for the others
// (ExactReferenceOptions::only_pixels).
std::vector<std::uint8_t> boundary_pixels(const std::vector<int>& regions);

}  // namespace gr::bench
