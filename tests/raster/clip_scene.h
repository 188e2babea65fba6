// A clip-space test scene shared by the adjoint tests: a grid whose bottom
// row is behind the camera (clipped triangles), a fan of many triangles around
// one vertex, and its rasterized G-buffer (float64).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "raster/kernel_checks.h"
#include "raster/rasterize.h"

namespace gr::testing {

// A clip-space mesh with its rasterized G-buffer.
struct ClipScene {
  int W = 0, H = 0, N = 0, M = 0, C = 3;
  std::vector<double> clip, attr, uv, depth;
  std::vector<std::int32_t> tris, id;
  void rasterize() {
    N = static_cast<int>(clip.size() / 4);
    M = static_cast<int>(tris.size() / 3);
    attr = random_vector(static_cast<std::size_t>(N) * C, -1, 1, 7);
    id.assign(static_cast<std::size_t>(W) * H, 0);
    uv.assign(2 * id.size(), 0.0);
    depth.assign(id.size(), 0.0);
    const raster::RasterSettings settings{W, H, raster::Cull::None};
    raster::rasterize_forward(raster::RasterParams<double>{clip.data(), N, tris.data(), M, settings}, id.data(),
                              uv.data(), depth.data());
  }
};

// A grid of nx x ny quads (ny >= 2) at depth z/w = 0.5 whose bottom row of
// vertices lies behind the camera (w < 0): the triangles of the bottom quads
// take the clipped form and cover the strip below the next row (y < -0.7),
// since a segment to a point behind the camera leaves the screen away from
// that point's projection. In front, a fan of `fan` triangles around one hub
// vertex (z/w = -0.45).
inline ClipScene grid_and_fan(int W, int H, int nx, int ny, int fan) {
  ClipScene s;
  s.W = W;
  s.H = H;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      // Projected position (sx, sy) and w; clip = (sx w, sy w, z, w).
      const double sx = -1.2 + 2.4 * i / nx + 0.01 * j, t = double(j - 1) / (ny - 1);
      const double sy = j == 0 ? 0.5 : -0.7 + 1.9 * t, w = j == 0 ? -0.3 : 0.3 + t;
      s.clip.insert(s.clip.end(), {sx * w, sy * w, 0.5 * w, w});
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::int32_t a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      s.tris.insert(s.tris.end(), {a, b, d, a, d, c});
    }
  // The fan, nearer than the grid (smaller z / w).
  const std::int32_t hub = static_cast<std::int32_t>(s.clip.size() / 4);
  s.clip.insert(s.clip.end(), {0.1, 0.05, -0.5, 1.0});
  for (int r = 0; r < fan; ++r) {
    const double a = 2.0 * M_PI * r / fan, w = 1.0 + 0.2 * std::sin(3 * a);
    s.clip.insert(s.clip.end(), {0.1 + 0.6 * std::cos(a) * w, 0.05 + 0.5 * std::sin(a) * w, -0.45 * w, w});
  }
  for (int r = 0; r < fan; ++r)
    s.tris.insert(s.tris.end(), {hub, hub + 1 + r, hub + 1 + (r + 1) % fan});
  s.rasterize();
  return s;
}

}  // namespace gr::testing
