// The rasterizer's documented per-pixel rule (raster/detail/rasterize_setup.h), one
// pixel at a time, for the kernel tests that hold the vectorized paths to it.
#pragma once

#include "raster/detail/rasterize_setup.h"

namespace gr::testing {

// Whether triangle s covers the centre of pixel (x, y); e: its edge values there.
inline bool covers_centre(const raster::detail::TriSetup& s, int x, int y, double e[3]) {
  bool in = true;
  for (int k = 0; k < 3; ++k) {
    e[k] = s.e[k].eval(x + 0.5, s.e[k].row(y + 0.5));
    in = in && s.e[k].inside(e[k]);
  }
  return in;
}

// Its depth there, and whether that passes the depth range test.
inline double centre_depth(const raster::detail::TriSetup& s, const double e[3]) {
  return e[0] * s.e[0].mz + e[1] * s.e[1].mz + e[2] * s.e[2].mz;
}
inline bool in_depth_range(const raster::detail::TriSetup& s, double z) { return !s.z_test || (z >= -1.0 && z <= 1.0); }

}  // namespace gr::testing
