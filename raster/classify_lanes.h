// Triangle classification kClassifyLanes triangles at a time, in vector lanes
// (issue 17: the G-buffer of a finely tessellated mesh). A mesh of a million
// triangles at 1024 x 1024 has boxes of a few pixel centres, and most of its
// triangles cover none: classify_triangle and box_fragments decided that one
// triangle at a time, with branches on random outcomes (facing, the canonical
// edge order, each centre's coverage) that the CPU mispredicts. Here the same
// expressions run over a batch with selections instead of branches.
#pragma once

#include <cstdint>

#include "raster/rasterize_setup.h"

namespace gr::raster::detail {

constexpr int kClassifyLanes = 16;

// Triangles [t0, t0 + n), n <= kClassifyLanes: k[i] and box[i] are what
// classify_triangle returns for triangle t0 + i, with two exceptions:
// - a triangle with a vertex not in front of the near plane, and not outside
//   one frustum plane, gets TriClass::Clipped without a box: call
//   classify_triangle for it;
// - a triangle classify_triangle calls Raster whose box holds at most
//   kMaxFragmentBox pixel centres (rasterize_scan.h) and covers none of them
//   (box_fragments would return 0) gets TriClass::NoPixel.
void classify_lanes(const Vertices& v, const std::int32_t* tris, std::int64_t t0, int n, int width, int height,
                    int cull, TriClass* k, PixelBox* box);

}  // namespace gr::raster::detail
