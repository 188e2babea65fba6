// Triangle classification kClassifyLanes triangles at a time, in vector lanes
// (issue 17: the G-buffer of a finely tessellated mesh). A mesh of a million
// triangles at 1024 x 1024 has boxes of a few pixel centres, and most of its
// triangles cover none. Deciding that one triangle at a time took branches on
// random outcomes (facing, the canonical edge order, each centre's coverage)
// that the CPU mispredicts; here the same expressions run over a batch with
// selections instead of branches, and the triangles whose box holds at most
// kMaxFragmentBox centres leave their fragments, to be binned like triangles.
#pragma once

#include <cstdint>

#include "raster/detail/rasterize_scan.h"
#include "raster/detail/rasterize_setup.h"

namespace gr::raster::detail {

constexpr int kClassifyLanes = 16;

// What classify_lanes leaves for the fragments of a small-box triangle it
// calls Raster: which pixel centres of its box it covers (slot s: column
// s mod w, row s / w of the box, w its width) and the edge values there.
struct LaneCoverage {
  double area2[kClassifyLanes];                  // 2A, the signed screen area doubled
  double e[kMaxFragmentBox][3][kClassifyLanes];  // e_k at slot s, as Edge::eval gives it (covered slots only)
  std::uint8_t slots[kClassifyLanes];            // bit s: slot s covered (0 unless the box is small, not empty)
};

// Triangles [t0, t0 + n), n <= kClassifyLanes: k[i] and box[i] are what
// classify_triangle returns for triangle t0 + i, with two exceptions:
// - a triangle with a vertex not in front of the near plane, and not outside
//   one frustum plane, gets TriClass::Clipped without a box: call
//   classify_triangle for it;
// - a triangle classify_triangle calls Raster whose box holds at most
//   kMaxFragmentBox pixel centres and covers none of them gets
//   TriClass::NoPixel (the same top-left rule as the scan).
void classify_lanes(const Vertices& v, const std::int32_t* tris, std::int64_t t0, int n, int width, int height,
                    int cull, TriClass* k, PixelBox* box, LaneCoverage* cover);

// The fragments of the small-box Raster triangle t in lane `lane` of the
// batch `cover` came from, box b: its covered centres that pass the depth
// range test, with depth and (u, v) as the tile scan computes them; returns
// how many it wrote to out (at most kMaxFragmentBox).
int lane_fragments(const Vertices& v, const std::int32_t* tris, std::int32_t t, const PixelBox& b,
                   const LaneCoverage& cover, int lane, int tiles_x, Fragment* out);

}  // namespace gr::raster::detail
