// project_vertices (raster/detail/rasterize_setup.h), which computes a vertex's
// four coordinates in one vector register, against the scalar expressions it
// stands for, bit for bit: clip copied (y negated with y_up), the screen
// position sx = W/2 (1 + x/w), sy = H/2 (1 - y/w), zn = z/w where the vertex is
// in front of the near plane and those are finite (else zeros), and the
// frustum outcode; float32 and float64 clip, y_up both ways, on random vertices
// and on vertices on and behind the planes, at w = 0, with signed zeros and
// with quotients that overflow.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "raster/detail/rasterize_setup.h"

using namespace gr::raster::detail;

namespace {

constexpr int W = 37, H = 29;

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// One vertex as the scalar code projects it.
template <class T>
void check_vertex(const T* in, const Vertices& v, std::size_t i, bool y_up) {
  double c[4];
  for (int k = 0; k < 4; ++k) c[k] = static_cast<double>(in[4 * i + k]);
  c[1] = y_up ? -c[1] : c[1];
  const bool in_front = c[3] > 0.0 && c[2] >= -c[3];
  const double sx = 0.5 * W * (1.0 + c[0] / c[3]), sy = 0.5 * H * (1.0 - c[1] / c[3]), zn = c[2] / c[3];
  const bool ok = in_front && std::isfinite(sx) && std::isfinite(sy) && std::isfinite(zn);
  const int code = (c[3] <= 0.0) | (c[0] > c[3]) << 1 | (c[0] < -c[3]) << 2 | (c[1] > c[3]) << 3 |
                   (c[1] < -c[3]) << 4 | (c[2] < -c[3]) << 5 | (c[2] > c[3]) << 6;
  INFO("vertex " << i << " (" << c[0] << ", " << c[1] << ", " << c[2] << ", " << c[3] << "), y_up " << y_up);
  for (int k = 0; k < 4; ++k) CHECK(same_bits(v.clip[4 * i + k], c[k]));
  CHECK(same_bits(v.screen[3 * i + 0], ok ? sx : 0.0));
  CHECK(same_bits(v.screen[3 * i + 1], ok ? sy : 0.0));
  CHECK(same_bits(v.screen[3 * i + 2], ok ? zn : 0.0));
  CHECK(static_cast<int>(v.front[i]) == static_cast<int>(ok));
  CHECK(static_cast<int>(v.outcode[i]) == code);
}

template <class T>
void check_all(const std::vector<T>& clip) {
  const std::int64_t n = static_cast<std::int64_t>(clip.size() / 4);
  Vertices reused;
  for (bool y_up : {false, true}) {
    const Vertices v = project_vertices(clip.data(), n, W, H, y_up);
    project_vertices_into(clip.data(), n, W, H, &reused, y_up);  // over the other orientation's values
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      check_vertex(clip.data(), v, i, y_up);
      check_vertex(clip.data(), reused, i, y_up);
    }
  }
}

// Random vertices (most in view, some beyond each plane or behind the eye)
// and hand-picked hard ones.
template <class T>
std::vector<T> vertices() {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(-1.5, 1.5), w(-0.5, 3.0);
  std::vector<T> clip;
  for (int i = 0; i < 2000; ++i) {
    const double wi = w(rng);
    for (double c : {u(rng) * wi, u(rng) * wi, u(rng) * wi, wi}) clip.push_back(static_cast<T>(c));
  }
  const T big = std::numeric_limits<T>::max(), tiny = std::numeric_limits<T>::denorm_min();
  const std::vector<std::vector<T>> hard = {
      {0, 0, 0, 0},       {1, -1, 1, 1},     {-1, 1, -1, 1},      {2, -2, 0.5, 1},  {0, 0, -1, 1},
      {0, 0, -1.01f, 1},  {-0.0f, -0.0f, -0.0f, 1}, {0, 0, 0, -0.0f}, {1, 1, 1, -1},   {0.5f, 0.5f, 0.5f, tiny},
      {big, -big, big, 1}, {big, big, -big, tiny}, {1, 1, 0, tiny}, {-big, 0, 0, big}, {3, 0, 2, 2}};
  for (const std::vector<T>& h : hard) clip.insert(clip.end(), h.begin(), h.end());
  return clip;
}

}  // namespace

TEST_CASE("project_vertices gives the scalar projection's bits for every vertex", "[raster][project]") {
  SECTION("float32 clip") { check_all(vertices<float>()); }
  SECTION("float64 clip") { check_all(vertices<double>()); }
}

TEST_CASE("a pooled Vertices comes back for reuse once its last owner lets go", "[raster][project]") {
  const Vertices* first = nullptr;
  {
    std::shared_ptr<Vertices> a = pooled_vertices();
    a->clip.assign(8, 1.0);
    first = a.get();
    std::shared_ptr<const Vertices> kept = a;  // a second owner
    a.reset();
    CHECK(kept->clip.size() == 8);
  }
  std::shared_ptr<Vertices> b = pooled_vertices();
  CHECK(b.get() == first);  // the same object, buffers kept
  CHECK(b->clip.capacity() >= 8);
}
