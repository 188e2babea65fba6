// Watertightness on closed procedural meshes: every pixel centre is hit by
// equally many front- and back-facing triangles (a ray enters a closed surface
// as often as it leaves), so no pixel is lost to a crack or drawn twice by a
// shared edge. Hits are counted by rasterizing each triangle alone.
#include <catch2/catch.hpp>

#include "ops/ops.h"
#include "raster/procedural.h"

using namespace gr;

namespace {

struct Layers {
  std::vector<int> front, back;  // hits per pixel
};

Layers count_layers(const raster::Mesh& mesh, const Tensor& eye, int size) {
  Tensor mvp = matmul(perspective(0.7, 1.0, 0.1, 10.0),
                      look_at(eye, Tensor::zeros({3}), Tensor::from_values({0, 1, 0}, {3})));
  Tensor clip = transform_points(mesh.positions, mvp);
  Layers layers{std::vector<int>(size * size, 0), std::vector<int>(size * size, 0)};
  const std::int32_t* t = mesh.triangles.data<std::int32_t>();
  for (std::int64_t k = 0; k < mesh.num_triangles(); ++k) {
    Tensor one = Tensor::from_vector<std::int32_t>({t[3 * k], t[3 * k + 1], t[3 * k + 2]}, {1, 3});
    GBuffer all = rasterize(clip, one, {size, size});
    GBuffer front = rasterize(clip, one, {size, size, Cull::Back});  // keeps front faces only
    const std::int32_t* a = all.tri_id.data<std::int32_t>();
    const std::int32_t* f = front.tri_id.data<std::int32_t>();
    for (int p = 0; p < size * size; ++p) {
      if (!a[p]) continue;
      (f[p] ? layers.front : layers.back)[p]++;
    }
  }
  return layers;
}

}  // namespace

TEST_CASE("rasterize: a closed icosphere covers every pixel centre exactly once from the front and once from the back",
          "[ops][rasterize][watertight]") {
  raster::Mesh mesh = raster::make_icosphere(3, 1.0f);
  Layers l = count_layers(mesh, Tensor::from_values({0.3, 0.5, 3.0}, {3}), 64);
  int covered = 0;
  for (std::size_t p = 0; p < l.front.size(); ++p) {
    INFO("pixel " << p);
    REQUIRE(l.front[p] == l.back[p]);
    REQUIRE(l.front[p] <= 1);  // convex: one layer each way
    covered += l.front[p];
  }
  CHECK(covered > 1000);  // the sphere fills a good part of the 64 x 64 view
}

TEST_CASE("rasterize: a closed torus has as many front as back layers at every pixel centre",
          "[ops][rasterize][watertight]") {
  raster::Mesh mesh = raster::make_torus(40, 16, 1.0f, 0.4f);
  Layers l = count_layers(mesh, Tensor::from_values({0.0, 0.6, 3.0}, {3}), 64);
  int two_layers = 0;
  for (std::size_t p = 0; p < l.front.size(); ++p) {
    INFO("pixel " << p);
    REQUIRE(l.front[p] == l.back[p]);
    two_layers += l.front[p] == 2;
  }
  CHECK(two_layers > 0);  // the view sees through the ring where it overlaps itself
}
