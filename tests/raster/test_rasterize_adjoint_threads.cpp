// The rasterize adjoint's parallel scatter on a mesh whose vertices are shared
// by many triangles of many pixels, with triangles clipped by the near plane:
// bit-identical for 1, 2 and 8 threads and for reversed triangles.
#include <catch2/catch.hpp>

#include <cstring>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/clip_scene.h"
#include "raster/kernel_checks.h"
#include "raster/rasterize.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

template <class T>
std::vector<T> clip_gradient(const ClipScene& s, const std::vector<std::int32_t>& tris, const std::vector<std::int32_t>& id,
                             const std::vector<double>& gu, const std::vector<double>& gd, int threads) {
  const std::vector<T> clip(s.clip.begin(), s.clip.end()), gu_t(gu.begin(), gu.end()), gd_t(gd.begin(), gd.end());
  std::vector<T> grad(clip.size(), T(0));
  set_num_threads(threads);
  rasterize_backward(RasterParams<T>{clip.data(), s.N, tris.data(), s.M, RasterSettings{s.W, s.H, Cull::None}},
                     id.data(), gu_t.data(), gd_t.data(), grad.data());
  set_num_threads(0);
  return grad;
}

template <class T>
void check_rasterize_adjoint_threads() {
  // 98304 pixels: six item ranges at 8 threads; grid vertices on six triangles.
  const ClipScene s = grid_and_fan(384, 256, 24, 16, 48);
  const std::vector<double> gu = random_vector(2 * s.id.size(), -1, 1, 4), gd = random_vector(s.id.size(), -1, 1, 5);
  const std::vector<T> one = clip_gradient<T>(s, s.tris, s.id, gu, gd, 1);
  // The clipped (homogeneous) path ran: a vertex behind the camera got a gradient.
  bool clipped_path = false;
  for (int v = 0; v < s.N; ++v)
    if (s.clip[4 * v + 3] < 0 && one[4 * v] != T(0)) clipped_path = true;
  CHECK(clipped_path);
  for (int threads : {2, 8}) {
    INFO(threads << " threads");
    const std::vector<T> other = clip_gradient<T>(s, s.tris, s.id, gu, gd, threads);
    CHECK(std::memcmp(one.data(), other.data(), one.size() * sizeof(T)) == 0);
  }
  // Reversed triangles, the G-buffer renumbered to match: the same bits.
  std::vector<std::int32_t> tris(s.tris.size()), id = s.id;
  for (int t = 0; t < s.M; ++t)
    for (int k = 0; k < 3; ++k) tris[3 * (s.M - 1 - t) + k] = s.tris[3 * t + k];
  for (std::int32_t& i : id)
    if (i) i = s.M + 1 - i;
  const std::vector<T> reversed = clip_gradient<T>(s, tris, id, gu, gd, 2);
  CHECK(std::memcmp(one.data(), reversed.data(), one.size() * sizeof(T)) == 0);
}

}  // namespace

TEST_CASE("rasterize adjoint: bit-identical for 1, 2 and 8 threads and reversed triangles on a shared-vertex mesh",
          "[raster][rasterize][determinism]") {
  SECTION("float32") { check_rasterize_adjoint_threads<float>(); }
  SECTION("float64") { check_rasterize_adjoint_threads<double>(); }
}
