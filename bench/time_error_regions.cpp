#include "bench/time_error_regions.h"

#include <cmath>

#include "autodiff/tape.h"
#include "ops/ops.h"

namespace gr::bench {

std::vector<int> pixel_regions(const TimeErrorScene& scene, const Tensor& points) {
  const int s = 8, W = scene.width() * s, H = scene.height() * s;
  RasterizeOptions ro;
  ro.width = W, ro.height = H, ro.cull = scene.cull();
  NoGradGuard no_grad;
  const GBuffer gb = rasterize(scene.clip_positions(points), scene.triangles(), ro);
  const std::int32_t* id = gb.tri_id.data<std::int32_t>();
  const std::vector<double> z = gb.depth.to_vector();
  // The object of each render vertex: the points' objects gathered as the colours are.
  const Tensor point_part = cast(scene.point_part(), DType::Float64);
  const std::vector<double> vertex_part = scene.vertex_colours(reshape(point_part, {scene.num_points(), 1})).to_vector();
  const std::int32_t* tri = scene.triangles().data<std::int32_t>();
  auto part = [&](std::int64_t p) { return vertex_part[static_cast<std::size_t>(tri[3 * (id[p] - 1)])]; };
  // Precedence: background boundary, then depth jump, then object change.
  auto rank = [](int kind) { return kind == kInterior ? 0 : kNumPixelRegions - kind; };
  auto dist = [&](std::int64_t p) {  // OpenGL perspective, near 0.1, far 10
    const double n = 0.1, f = 10;
    return 2 * n * f / ((f + n) - z[p] * (f - n));
  };
  std::vector<int> region(static_cast<std::size_t>(scene.width() * scene.height()), kInterior);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::int64_t p = std::int64_t(y) * W + x;
      for (const std::int64_t q : {x + 1 < W ? p + 1 : -1, y + 1 < H ? p + W : -1}) {
        if (q < 0) continue;
        int kind = kInterior;
        if ((id[p] == 0) != (id[q] == 0)) kind = kBackgroundBoundary;
        else if (id[p] != 0 && std::abs(dist(p) - dist(q)) > 0.1) kind = kDepthJump;
        else if (id[p] != 0 && part(p) != part(q)) kind = kObjectChange;
        if (!kind) continue;
        for (const std::int64_t r : {p, q}) {
          int& g = region[(r / W / s) * scene.width() + (r % W) / s];
          if (rank(kind) > rank(g)) g = kind;
        }
      }
    }
  return region;
}

std::vector<std::uint8_t> boundary_pixels(const std::vector<int>& regions) {
  std::vector<std::uint8_t> flags(regions.size());
  for (std::size_t i = 0; i < regions.size(); ++i) flags[i] = regions[i] != kInterior;
  return flags;
}

}  // namespace gr::bench
