// Internal to the rasterizer: the per-tile scan of one triangle into a tile's
// depth / id / barycentric buffer (the forward pass's inner loop).
//
// Per pixel centre p the three edge values are e_k = ((px - ax) dy - (py - ay) dx) + c
// (see rasterize_setup.h); the pixel is covered when every e_k > 0, or == 0 on a
// top-left edge; depth = e0 mz0 + e1 mz1 + e2 mz2, u = e1 mu1, v = e2 mu2; the
// smallest (depth, id) key wins. The scan evaluates exactly these expressions;
// it only reorganizes the work (column terms (px - ax) dy computed once per
// triangle and tile, coverage of a row two pixels at a time, depth and (u, v)
// for covered pixels only), so results are bit-identical to a plain loop.
#pragma once

#include <cstdint>

#include "raster/detail/rasterize_setup.h"

namespace gr::raster::detail {

constexpr int kTile = 32;  // screen tiles are kTile x kTile pixels
constexpr int kTilePixels = kTile * kTile;

// One tile's pixels: depth, triangle index (-1 = none) and (u, v).
struct TileBuffer {
  double z[kTilePixels], u[kTilePixels], v[kTilePixels];
  std::int32_t id[kTilePixels];
  int covered;  // pixels with id >= 0
  double zmax;  // largest z over the tile once every pixel is covered, else +inf
  // Depth peeling: when `floor` is set, slot p accepts only keys (z, id)
  // strictly greater than (fz[p], fid[p]) (0-based id; +inf, INT32_MAX = none).
  bool floor = false;
  double fz[kTilePixels];
  std::int32_t fid[kTilePixels];
};

// A covered pixel centre of a small triangle, computed before binning
// (classify_lanes.h, lane_fragments): where = tile * kTilePixels + slot; z, u, v
// as the scan computes them, after the triangle's depth range test.
struct Fragment {
  double z, u, v;
  std::int32_t id, where;
};
// Triangles whose box holds at most this many pixel centres leave fragments.
constexpr int kMaxFragmentBox = 4;

// Resolves fragments of one tile into tb (the peeling floor and the
// (depth, id) test, as for a scanned triangle; the order does not matter).
void resolve_fragments(const Fragment* f, std::int64_t n, TileBuffer& tb);

// Scans triangle t (tris[3t..3t+2]) over its pixel box b clipped to the tile
// [tx0, tx1] x [ty0, ty1] (inclusive pixel indices; the tile's pixel (x, y) is
// tb slot (y - ty0) kTile + x - tx0).
void scan_triangle(const Vertices& v, const std::int32_t* tris, std::int32_t t, const PixelBox& b,
                   int tx0, int ty0, int tx1, int ty1, int width, int height, TileBuffer& tb);

}  // namespace gr::raster::detail
