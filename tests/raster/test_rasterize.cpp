// Tests of the rasterizer kernels: coverage and G-buffer values, the tie rule
// (watertight shared edges and vertices on pixel centres), culling, near-plane
// clipping, determinism over threads and triangle order, degenerate input and
// bad input. (The differentiable G-buffer and its adjoint: test_barycentric_gbuffer.cpp.)
// raster/detail/rasterize_setup.cpp (edge setup, classification, validation) is tested through these.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <array>
#include <functional>
#include <map>
#include <numeric>
#include <random>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/rasterize.h"
#include "raster/kernel_checks.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

struct GBuffer {
  std::vector<std::int32_t> id;
  std::vector<double> uv, depth;
  RasterStats stats;
};

template <class T>
RasterParams<T> params(const std::vector<T>& clip, const std::vector<std::int32_t>& tris, int W, int H,
                       Cull cull = Cull::None, bool front_to_back = false) {
  return {clip.data(), static_cast<std::int64_t>(clip.size() / 4), tris.data(),
          static_cast<std::int64_t>(tris.size() / 3), RasterSettings{W, H, cull, front_to_back}};
}

GBuffer render(const std::vector<double>& clip, const std::vector<std::int32_t>& tris, int W, int H,
               Cull cull = Cull::None, bool front_to_back = false) {
  GBuffer g;
  g.id.resize(W * H);
  g.uv.resize(2 * W * H);
  g.depth.resize(W * H);
  rasterize_forward(params(clip, tris, W, H, cull, front_to_back), g.id.data(), g.uv.data(), g.depth.data(),
                    &g.stats);
  return g;
}

// Clip coordinates of a screen point (xs, ys) at NDC depth z with the given w.
void push_screen_vertex(std::vector<double>& clip, double xs, double ys, double z, double w, int W,
                        int H) {
  clip.insert(clip.end(), {w * (xs / (0.5 * W) - 1.0), w * (1.0 - ys / (0.5 * H)), w * z, w});
}

// Number of triangles covering each pixel, each rendered alone.
std::vector<int> hit_count(const std::vector<double>& clip, const std::vector<std::int32_t>& tris,
                           int W, int H) {
  std::vector<int> count(W * H, 0);
  for (std::size_t t = 0; t < tris.size() / 3; ++t) {
    const std::vector<std::int32_t> one(tris.begin() + 3 * t, tris.begin() + 3 * t + 3);
    const GBuffer g = render(clip, one, W, H);
    for (int p = 0; p < W * H; ++p) count[p] += g.id[p] != 0;
  }
  return count;
}

// A regular grid of (n x n) quads on screen, two triangles each, alternating
// winding and diagonal direction; vertices optionally jittered.
void screen_grid(int n, double x0, double y0, double step, double jitter, unsigned seed, int W, int H,
                 std::vector<double>& clip, std::vector<std::int32_t>& tris) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-jitter, jitter), dw(0.5, 2.0), dz(-0.5, 0.5);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const bool border = i == 0 || j == 0 || i == n || j == n;
      const double jx = border ? 0 : d(rng), jy = border ? 0 : d(rng);
      push_screen_vertex(clip, x0 + i * step + jx, y0 + j * step + jy, dz(rng),
                         jitter > 0 ? dw(rng) : 1.0, W, H);
    }
  auto idx = [&](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = idx(i, j), b = idx(i + 1, j), c = idx(i + 1, j + 1), e = idx(i, j + 1);
      const bool flip = (i + j) % 2 == 1;
      if ((i * 7 + j * 3) % 2 == 0) {
        tris.insert(tris.end(), {a, b, c});
        if (flip) tris.insert(tris.end(), {a, e, c});
        else tris.insert(tris.end(), {a, c, e});
      } else {
        tris.insert(tris.end(), {a, b, e});
        if (flip) tris.insert(tris.end(), {b, e, c});
        else tris.insert(tris.end(), {b, c, e});
      }
    }
}

// OpenGL perspective projection of a view-space point.
void push_view_vertex(std::vector<double>& clip, double x, double y, double z, double fovy = 1.2,
                      double aspect = 1.0, double n = 0.1, double f = 100.0) {
  const double t = 1.0 / std::tan(0.5 * fovy);
  clip.insert(clip.end(), {t / aspect * x, t * y, (f + n) / (n - f) * z + 2 * f * n / (n - f), -z});
}

}  // namespace

TEST_CASE("rasterize: a counter-clockwise NDC triangle is front facing and fills its interior",
          "[raster][rasterize]") {
  const int W = 8, H = 8;
  std::vector<double> clip;
  // Screen (0,8) (8,8) (0,0): the lower-left half, CCW in NDC.
  push_screen_vertex(clip, 0, 8, 0.25, 1, W, H);
  push_screen_vertex(clip, 8, 8, 0.25, 1, W, H);
  push_screen_vertex(clip, 0, 0, 0.25, 1, W, H);
  const std::vector<std::int32_t> tris = {0, 1, 2};
  const GBuffer g = render(clip, tris, W, H);
  int covered = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const int p = j * W + i;
      const double px = i + 0.5, py = j + 0.5;
      // Inside strictly below the diagonal x = y; on it the tie rule decides.
      if (px < py) CHECK(g.id[p] == 1);
      if (px > py) CHECK(g.id[p] == 0);
      if (g.id[p] == 0) continue;
      ++covered;
      // u = weight of vertex 1 = x/8, v = weight of vertex 2 = (8 - y)/8.
      CHECK(g.uv[2 * p] == Approx(px / 8).margin(1e-15));
      CHECK(g.uv[2 * p + 1] == Approx((8 - py) / 8).margin(1e-15));
      CHECK(g.depth[p] == Approx(0.25));
    }
  CHECK(covered >= 28);
  CHECK(g.id[7] == 0);
  CHECK(g.depth[7] == kBackgroundDepth);
  CHECK(render(clip, tris, W, H, Cull::Back).stats.rasterized == 1);
  const GBuffer front_culled = render(clip, tris, W, H, Cull::Front);
  CHECK(front_culled.stats.culled_face == 1);
  CHECK(std::all_of(front_culled.id.begin(), front_culled.id.end(), [](int i) { return i == 0; }));
  // The clockwise copy is a back face.
  CHECK(render(clip, {0, 2, 1}, W, H, Cull::Back).stats.culled_face == 1);
}

TEST_CASE("rasterize: the nearer triangle wins, equal depths go to the smaller id",
          "[raster][rasterize]") {
  const int W = 16, H = 16;
  std::vector<double> clip;
  for (double z : {0.5, -0.5, 0.5}) {
    push_screen_vertex(clip, 1, 1, z, 1, W, H);
    push_screen_vertex(clip, 15, 1, z, 1, W, H);
    push_screen_vertex(clip, 1, 15, z, 1, W, H);
  }
  const GBuffer g = render(clip, {6, 7, 8, 0, 1, 2, 3, 4, 5}, W, H);
  CHECK(g.id[3 * W + 3] == 3);  // z = -0.5 is nearest
  const GBuffer tie = render(clip, {6, 7, 8, 0, 1, 2}, W, H);
  CHECK(tie.id[3 * W + 3] == 1);  // equal depth: smaller id
  const GBuffer tie2 = render(clip, {0, 1, 2, 6, 7, 8}, W, H);
  CHECK(tie2.id[3 * W + 3] == 1);
}

TEST_CASE("rasterize: a grid with edges and vertices exactly on pixel centres covers every pixel once",
          "[raster][rasterize][watertight]") {
  const int W = 32, H = 32;
  std::vector<double> clip;
  std::vector<std::int32_t> tris;
  // Vertices on pixel centres (4i + 0.5); diagonals pass through pixel centres too.
  screen_grid(7, 2.5, 2.5, 4.0, 0.0, 1, W, H, clip, tris);
  const std::vector<int> count = hit_count(clip, tris, W, H);
  int inside = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const double px = i + 0.5, py = j + 0.5;
      const bool interior = px > 2.5 && px < 30.5 && py > 2.5 && py < 30.5;
      if (interior) {
        ++inside;
        INFO("pixel " << i << "," << j);
        CHECK(count[j * W + i] == 1);
      }
      CHECK(count[j * W + i] <= 1);
    }
  CHECK(inside == 27 * 27);
}

TEST_CASE("rasterize: a jittered perspective grid is watertight for both windings",
          "[raster][rasterize][watertight]") {
  const int W = 40, H = 36;
  for (unsigned seed : {2u, 3u, 4u}) {
    std::vector<double> clip;
    std::vector<std::int32_t> tris;
    screen_grid(9, 1.0, 1.0, 3.75, 1.2, seed, W, H, clip, tris);
    const std::vector<int> count = hit_count(clip, tris, W, H);
    for (int j = 0; j < H; ++j)
      for (int i = 0; i < W; ++i) {
        const double px = i + 0.5, py = j + 0.5;
        if (px > 1.0 && px < 34.75 && py > 1.0 && py < 34.75) {
          INFO("seed " << seed << " pixel " << i << "," << j);
          CHECK(count[j * W + i] == 1);
        }
      }
  }
}

TEST_CASE("rasterize: a closed sphere is covered exactly twice inside its silhouette",
          "[raster][rasterize][watertight]") {
  // Subdivided octahedron projected in perspective (shared vertices).
  std::vector<std::array<double, 3>> pos = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0},
                                            {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<std::array<int, 3>> faces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                           {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int level = 0; level < 3; ++level) {
    std::vector<std::array<int, 3>> next;
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      std::array<double, 3> m;
      double len = 0;
      for (int k = 0; k < 3; ++k) len += (m[k] = 0.5 * (pos[a][k] + pos[b][k])) * m[k];
      for (double& c : m) c /= std::sqrt(len);
      pos.push_back(m);
      return mid[key] = static_cast<int>(pos.size()) - 1;
    };
    for (const auto& f : faces) {
      const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      next.push_back({f[0], a, c});
      next.push_back({f[1], b, a});
      next.push_back({f[2], c, b});
      next.push_back({a, b, c});
    }
    faces = next;
  }
  const int W = 48, H = 40;
  std::vector<double> clip;
  for (const auto& p : pos) push_view_vertex(clip, 0.9 * p[0] + 0.13, 0.9 * p[1] - 0.07, 0.9 * p[2] - 2.6, 1.0, 1.2);
  std::vector<std::int32_t> tris;
  for (const auto& f : faces) tris.insert(tris.end(), {f[0], f[1], f[2]});
  const std::vector<int> count = hit_count(clip, tris, W, H);
  int twice = 0;
  for (int p = 0; p < W * H; ++p) {
    INFO("pixel " << p % W << "," << p / W);
    CHECK((count[p] == 0 || count[p] == 2));
    twice += count[p] == 2;
  }
  CHECK(twice > 300);
  // With back faces culled, exactly the silhouette's pixels remain, each once.
  const GBuffer g = render(clip, tris, W, H, Cull::Back);
  int front = 0;
  for (int p = 0; p < W * H; ++p) front += g.id[p] != 0;
  CHECK(front == twice);
}

TEST_CASE("rasterize: the G-buffer is identical for 1 and 2 threads and shuffled triangles",
          "[raster][rasterize][determinism]") {
  const int W = 150, H = 130, T = 3000;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> d(-1.2, 1.2), dw(0.4, 2.0), ds(-0.15, 0.15);
  std::vector<double> clip;
  std::vector<std::int32_t> tris;
  for (int t = 0; t < T; ++t) {
    const double cx = d(rng), cy = d(rng), w = dw(rng), cz = 0.8 * d(rng);
    for (int k = 0; k < 3; ++k) {
      // Some vertices behind the camera to exercise the clipped path.
      const double wk = (t % 50 == 0 && k == 0) ? -0.5 : w + 0.1 * ds(rng);
      clip.insert(clip.end(), {wk * (cx + 2 * ds(rng)), wk * (cy + 2 * ds(rng)), wk * (cz + ds(rng)), wk});
      tris.push_back(3 * t + k);
    }
  }
  gr::set_num_threads(1);
  const GBuffer g1 = render(clip, tris, W, H);
  gr::set_num_threads(2);
  const GBuffer g2 = render(clip, tris, W, H);
  gr::set_num_threads(0);
  CHECK(g1.stats.clipped_near > 0);
  CHECK(g1.id == g2.id);
  CHECK(g1.uv == g2.uv);
  CHECK(g1.depth == g2.depth);

  // Shuffle the triangle list: same image up to the id permutation.
  std::vector<int> perm(T);
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<std::int32_t> shuffled(3 * T);
  for (int n = 0; n < T; ++n)
    for (int k = 0; k < 3; ++k) shuffled[3 * n + k] = tris[3 * perm[n] + k];
  const GBuffer gs = render(clip, shuffled, W, H);
  bool same_ids = true;
  for (int p = 0; p < W * H; ++p)
    same_ids &= (gs.id[p] == 0 ? 0 : perm[gs.id[p] - 1] + 1) == g1.id[p];
  CHECK(same_ids);
  CHECK(gs.uv == g1.uv);
  CHECK(gs.depth == g1.depth);
}

// Overlapping layers: big quads that cover whole tiles at a few depths (some
// equal, so ties decide), many small triangles in between, slivers, and some
// triangles crossing w = 0.
void layered_scene(int W, int H, std::vector<double>& clip, std::vector<std::int32_t>& tris) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  auto quad = [&](double z) {
    const std::int32_t b = static_cast<std::int32_t>(clip.size() / 4);
    for (const auto& xy : {std::array<double, 2>{-3, W + 3.0}, {W + 3.0, W + 3.0}, {W + 3.0, -3}, {-3, -3}})
      push_screen_vertex(clip, xy[0], xy[1], z, 1.0, W, H);
    tris.insert(tris.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
  };
  for (int t = 0; t < 1500; ++t) {
    if (t % 300 == 0) quad(0.2 + 0.1 * (t / 600));  // z = 0.2, 0.2, 0.3, 0.3, 0.4
    const std::int32_t b = static_cast<std::int32_t>(clip.size() / 4);
    const double cx = u(rng) * W, cy = u(rng) * H, r = t % 7 == 0 ? 25 : 3, z = 2 * u(rng) - 1;
    for (int k = 0; k < 3; ++k) {
      const double w = (t % 97 == 0 && k == 0) ? -0.3 : 0.5 + u(rng);
      const double sliver = t % 13 == 0 ? 0.01 : 1.0;
      push_screen_vertex(clip, cx + r * (u(rng) - 0.5), cy + sliver * r * (u(rng) - 0.5), z + 0.05 * u(rng), w, W, H);
    }
    tris.insert(tris.end(), {b, b + 1, b + 2});
  }
}

TEST_CASE("rasterize: front-to-back order gives the identical G-buffer",
          "[raster][rasterize][determinism]") {
  const int W = 140, H = 100;
  std::vector<double> clip;
  std::vector<std::int32_t> tris;
  layered_scene(W, H, clip, tris);
  const GBuffer ref = render(clip, tris, W, H);
  CHECK(ref.stats.clipped_near > 0);
  for (int threads : {1, 2}) {
    gr::set_num_threads(threads);
    for (Cull cull : {Cull::None, Cull::Back}) {
      const GBuffer a = render(clip, tris, W, H, cull, false);
      const GBuffer b = render(clip, tris, W, H, cull, true);
      CHECK(a.id == b.id);
      CHECK(a.uv == b.uv);
      CHECK(a.depth == b.depth);
      if (cull == Cull::None) {
        CHECK(b.id == ref.id);
        CHECK(b.depth == ref.depth);
      }
    }
  }
  gr::set_num_threads(0);
}

TEST_CASE("rasterize: reused scratch buffers leave no trace between calls of different sizes",
          "[raster][rasterize][determinism]") {
  const int W = 140, H = 100;
  std::vector<double> big_clip, small_clip;
  std::vector<std::int32_t> big_tris, small_tris;
  layered_scene(W, H, big_clip, big_tris);
  screen_grid(3, 10, 10, 20, 2.0, 5, 64, 48, small_clip, small_tris);
  const GBuffer first = render(big_clip, big_tris, W, H);
  const GBuffer small_first = render(small_clip, small_tris, 64, 48);
  const GBuffer again = render(big_clip, big_tris, W, H, Cull::None, true);
  const GBuffer small_again = render(small_clip, small_tris, 64, 48);
  CHECK(again.id == first.id);
  CHECK(again.uv == first.uv);
  CHECK(again.depth == first.depth);
  CHECK(small_again.id == small_first.id);
  CHECK(small_again.uv == small_first.uv);
}

TEST_CASE("rasterize: a triangle crossing w = 0 renders exactly its visible part",
          "[raster][rasterize][near]") {
  const int W = 40, H = 32;
  std::vector<double> clip;
  push_view_vertex(clip, -0.6, -0.5, -1.0);
  push_view_vertex(clip, 0.7, -0.4, -1.5);
  push_view_vertex(clip, 0.1, 0.3, 0.6);
  const GBuffer g = render(clip, {0, 1, 2}, W, H);
  // Reference: solve sum b_k (x_k - px w_k, y_k - py w_k, 1) = (0, 0, 1) per pixel.
  int covered = 0, checked = 0;
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      const double px = (i + 0.5) / (0.5 * W) - 1, py = 1 - (j + 0.5) / (0.5 * H);
      double m[3][3];
      for (int k = 0; k < 3; ++k) {
        const double* c = &clip[4 * k];
        m[0][k] = c[0] - px * c[3];
        m[1][k] = c[1] - py * c[3];
        m[2][k] = 1;
      }
      // Cramer's rule for b.
      auto det3 = [](double a[3][3]) {
        return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
               a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
               a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
      };
      const double det = det3(m);
      double b[3];
      for (int k = 0; k < 3; ++k) {
        double mk[3][3];
        std::copy(&m[0][0], &m[0][0] + 9, &mk[0][0]);
        mk[0][k] = 0;
        mk[1][k] = 0;
        mk[2][k] = 1;
        b[k] = det3(mk) / det;
      }
      double w = 0, z = 0;
      for (int k = 0; k < 3; ++k) {
        w += b[k] * clip[4 * k + 3];
        z += b[k] * clip[4 * k + 2];
      }
      const bool in = b[0] > 1e-9 && b[1] > 1e-9 && b[2] > 1e-9 && w > 0 && z / w > -1 + 1e-9;
      const bool out = b[0] < -1e-9 || b[1] < -1e-9 || b[2] < -1e-9 || w < 0 || z / w < -1 - 1e-9;
      const int p = j * W + i;
      covered += g.id[p] != 0;
      if (in) {
        ++checked;
        CHECK(g.id[p] == 1);
        // Stored (u, v): screen-space barycentrics lambda_k = b_k w_k / sum b_j w_j.
        CHECK(g.uv[2 * p] == Approx(b[1] * clip[7] / w).margin(1e-9));
        CHECK(g.uv[2 * p + 1] == Approx(b[2] * clip[11] / w).margin(1e-9));
        CHECK(g.depth[p] == Approx(z / w).margin(1e-9));
      }
      if (out) CHECK(g.id[p] == 0);
    }
  CHECK(checked > 100);
  CHECK(covered >= checked);
  CHECK(all_finite(g.uv));
  CHECK(all_finite(g.depth));
}

TEST_CASE("rasterize: triangles behind the camera or outside the frustum contribute nothing",
          "[raster][rasterize][near]") {
  const int W = 16, H = 16;
  std::vector<double> clip;
  push_view_vertex(clip, -0.5, -0.5, 1.0);
  push_view_vertex(clip, 0.5, -0.5, 2.0);
  push_view_vertex(clip, 0.0, 0.5, 1.5);
  push_view_vertex(clip, 5.0, -0.5, -1.0);  // right of the frustum
  push_view_vertex(clip, 6.0, -0.5, -1.0);
  push_view_vertex(clip, 5.5, 0.5, -1.0);
  push_view_vertex(clip, -0.5, -0.5, -0.05);  // before the near plane
  push_view_vertex(clip, 0.5, -0.5, -0.05);
  push_view_vertex(clip, 0.0, 0.5, -0.07);
  const GBuffer g = render(clip, {0, 1, 2, 3, 4, 5, 6, 7, 8}, W, H);
  CHECK(std::all_of(g.id.begin(), g.id.end(), [](int i) { return i == 0; }));
  CHECK(g.stats.culled_outside == 3);
}

// Every id is a triangle of the list or 0, and every G-buffer value finite.
template <class T>
void check_gbuffer_of_extreme_clip(int triangles, unsigned seed) {
  const int W = 16, H = 16, vertices = 300;
  const std::vector<T> clip = extreme_clip<T>(vertices, seed);
  const std::vector<std::int32_t> tris = random_triangles(triangles, vertices, seed + 1);
  std::vector<std::int32_t> id(W * H, -1);
  std::vector<T> uv(2 * W * H), depth(W * H);
  rasterize_forward(params(clip, tris, W, H), id.data(), uv.data(), depth.data());
  for (std::int32_t t : id) REQUIRE((t >= 0 && t <= triangles));
  for (T x : uv) REQUIRE(std::isfinite(x));
  for (T x : depth) REQUIRE(std::isfinite(x));
}

TEST_CASE("rasterize: near-plane crossings that round to w = 0 stay within the clipper's buffers",
          "[raster][rasterize][near]") {
  // Clipping a triangle at z >= -w can give a crossing whose w rounds to 0 or
  // below; the clip at w >= eps then sees alternating signs and returns up to
  // 6 vertices (a held-out probe's finding: it wrote past a 5-vertex buffer,
  // which the sanitizer job reports, and crashed Python's rasterize).
  SECTION("the probe's triangles") {
    const std::vector<double> crossing = {-0.4, 0.1, -1e300, 1, 1, 0.1, 0.5, 1e-300, 1, 0.1, 0.5, 0};
    const GBuffer g = render(crossing, {0, 1, 2}, 16, 16);
    CHECK(std::count(g.id.begin(), g.id.end(), 0) + std::count(g.id.begin(), g.id.end(), 1) == 256);
    const std::vector<float> crossing_f = {0.0f, 0.0f, 1.0f, 8.450318e-30f, 0.0f, 0.0f, -6e21f, 3.1452960e16f,
                                           -1.4666089e-06f, 0.13414650f, 0.0f, 1.0f};
    std::vector<std::int32_t> id(256, -1);
    std::vector<float> uv(512), depth(256);
    rasterize_forward(params(crossing_f, {0, 1, 2}, 16, 16), id.data(), uv.data(), depth.data());
    CHECK(std::count(id.begin(), id.end(), 0) + std::count(id.begin(), id.end(), 1) == 256);
  }
  SECTION("random triangles over every magnitude, float32 and float64") {
    for (unsigned seed = 0; seed < 4; ++seed) {
      check_gbuffer_of_extreme_clip<float>(2000, seed);
      check_gbuffer_of_extreme_clip<double>(2000, seed);
    }
  }
}

TEST_CASE("rasterize: degenerate triangles, slivers and vertices on pixel centres stay finite",
          "[raster][rasterize][degenerate]") {
  const int W = 32, H = 32;
  std::vector<double> clip;
  push_screen_vertex(clip, 2.5, 2.5, 0, 1, W, H);    // 0: on a pixel centre
  push_screen_vertex(clip, 20.5, 2.5, 0, 1, W, H);   // 1
  push_screen_vertex(clip, 11.5, 2.5, 0, 1, W, H);   // 2: collinear with 0, 1
  push_screen_vertex(clip, 2.5, 2.5, 0.3, 1, W, H);  // 3: same point as 0
  push_screen_vertex(clip, 30.5, 20.5 + 1e-9, 0, 1, W, H);  // 4, 5: sliver through pixel centres
  push_screen_vertex(clip, 1.5, 5.5, 0, 2, W, H);
  push_screen_vertex(clip, 30.5, 20.5, 0.1, 1, W, H);
  push_screen_vertex(clip, 20.5, 20.5, 0.1, 0.5, W, H);  // 7
  push_screen_vertex(clip, 20.5, 30.5, 0.1, 1, W, H);    // 8
  const std::vector<std::int32_t> tris = {0, 1, 2, 0, 0, 1, 0, 3, 1, 4, 5, 6, 7, 8, 6, 6, 4, 5};
  const GBuffer g = render(clip, tris, W, H);
  CHECK(g.stats.culled_zero_area >= 2);
  CHECK(all_finite(g.uv));
  CHECK(all_finite(g.depth));
}

