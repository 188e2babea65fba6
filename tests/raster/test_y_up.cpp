// RasterSettings::y_up (row 0 at the bottom) in every kernel that reads clip
// positions: bit for bit the y_up = false result on a copy of clip with y
// negated, and gradients equal to that run's with their y negated back (both
// accumulated onto a random start, so the += is checked as well). Random
// scenes with shared edges, intersecting sheets and triangles crossing the
// near plane or behind the camera; float32 and float64.
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "raster/barycentric_gbuffer.h"
#include "raster/blended_pairs.h"
#include "raster/clip_scene.h"
#include "raster/kernel_checks.h"
#include "raster/project.h"
#include "raster/rasterize.h"

using namespace gr;
using namespace gr::raster;

namespace {

constexpr int W = 37, H = 29;
constexpr std::int64_t P = std::int64_t(W) * H;

struct Mesh {
  std::vector<double> clip;
  std::vector<std::int32_t> tris;
};

// Two jittered grid sheets cutting through each other (shared edges, a
// silhouette and an intersection curve), a triangle crossing the near plane
// (z < -w at one vertex) and one with a vertex behind the camera (w < 0).
Mesh random_scene(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Mesh m;
  const int n = 7;
  for (int sheet = 0; sheet < 2; ++sheet) {
    const std::int32_t base = static_cast<std::int32_t>(m.clip.size() / 4);
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const double x = -1.1 + 2.2 * i / n + 0.05 * u(rng), y = -1.1 + 2.2 * j / n + 0.05 * u(rng);
        const double z = sheet == 0 ? 0.3 * u(rng) : 0.4 * x + 0.1 * u(rng), w = 1.1 + 0.4 * u(rng);
        m.clip.insert(m.clip.end(), {x * w, y * w, z * w, w});
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const std::int32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
        m.tris.insert(m.tris.end(), {a, b, d, a, d, c});
      }
  }
  const std::int32_t k = static_cast<std::int32_t>(m.clip.size() / 4);
  const double extra[] = {-0.3, 0.2, -1.5, 1.0, 0.5, 0.7, 0.3, 1.1, -0.8, 0.9, 0.1, 1.2,  // crosses z = -w
                          -0.6, -0.5, 0.2, 1.0, 0.7, -0.4, 0.1, 0.9, 0.05, 0.3, -0.4, -0.3};  // w < 0
  for (double e : extra) m.clip.push_back(e + 0.01 * u(rng));
  m.tris.insert(m.tris.end(), {k, k + 1, k + 2, k + 3, k + 4, k + 5});
  return m;
}

// testing::grid_and_fan's mesh: clipped bottom row (w < 0) and a fan.
Mesh grid_and_fan() {
  const testing::ClipScene s = testing::grid_and_fan(W, H, 5, 4, 9);
  return {s.clip, s.tris};
}

template <class T>
std::vector<T> as(const std::vector<double>& v) {
  return std::vector<T>(v.begin(), v.end());
}

// clip (or a gradient of it, N x 4) with y negated.
template <class T>
std::vector<T> negated_y(std::vector<T> v) {
  for (std::size_t i = 1; i < v.size(); i += 4) v[i] = -v[i];
  return v;
}

template <class U>
bool same_bits(const std::vector<U>& a, const std::vector<U>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(U)) == 0;
}

template <class T>
struct GBuffer {
  std::vector<std::int32_t> id;
  std::vector<T> uv, depth;
  std::vector<double> key;
  RasterStats stats;
};

template <class T>
RasterParams<T> raster_params(const std::vector<T>& clip, const Mesh& m, bool y_up, Cull cull = Cull::None) {
  RasterParams<T> p;
  p.clip = clip.data();
  p.num_vertices = static_cast<std::int64_t>(clip.size() / 4);
  p.tris = m.tris.data();
  p.num_tris = static_cast<std::int64_t>(m.tris.size() / 3);
  p.settings.width = W;
  p.settings.height = H;
  p.settings.cull = cull;
  p.settings.y_up = y_up;
  return p;
}

// A G-buffer; with `floor`, the next depth-peeling layer behind it.
template <class T>
GBuffer<T> rasterize(RasterParams<T> p, const GBuffer<T>* floor = nullptr) {
  GBuffer<T> g{std::vector<std::int32_t>(P), std::vector<T>(2 * P), std::vector<T>(P), std::vector<double>(P), {}};
  if (floor) {
    p.floor_id = floor->id.data();
    p.floor_z = floor->key.data();
  }
  rasterize_forward(p, g.id.data(), g.uv.data(), g.depth.data(), &g.stats, g.key.data());
  return g;
}

template <class T>
bool same(const GBuffer<T>& a, const GBuffer<T>& b) {
  const RasterStats &s = a.stats, &t = b.stats;
  return same_bits(a.id, b.id) && same_bits(a.uv, b.uv) && same_bits(a.depth, b.depth) && same_bits(a.key, b.key) &&
         s.culled_outside == t.culled_outside && s.culled_zero_area == t.culled_zero_area &&
         s.culled_face == t.culled_face && s.culled_no_pixel == t.culled_no_pixel && s.rasterized == t.rasterized &&
         s.clipped_near == t.clipped_near;
}

template <class T>
std::vector<T> random_t(std::size_t n, unsigned seed) {
  return as<T>(testing::random_vector(n, -1, 1, seed));
}

std::vector<Mesh> scenes() { return {random_scene(1), random_scene(2), random_scene(3), grid_and_fan()}; }

}  // namespace

TEMPLATE_TEST_CASE("y_up: rasterize gives the G-buffer of y_up = false on clip with y negated", "[rasterize][y_up]",
                   float, double) {
  using T = TestType;
  for (const Mesh& m : scenes()) {
    const std::vector<T> clip = as<T>(m.clip), flipped = negated_y(clip);
    for (Cull cull : {Cull::None, Cull::Back, Cull::Front}) {
      const GBuffer<T> up = rasterize(raster_params(clip, m, true, cull));
      const GBuffer<T> ref = rasterize(raster_params(flipped, m, false, cull));
      REQUIRE(same(up, ref));
      // The next depth-peeling layer too.
      REQUIRE(same(rasterize(raster_params(clip, m, true, cull), &up),
                   rasterize(raster_params(flipped, m, false, cull), &ref)));
      // The option does something: rows in the other order.
      REQUIRE_FALSE(same_bits(up.id, rasterize(raster_params(clip, m, false, cull)).id));
    }
    // front_to_back changes only the work.
    RasterParams<T> f2b = raster_params(clip, m, true);
    f2b.settings.front_to_back = true;
    REQUIRE(same_bits(rasterize(f2b).id, rasterize(raster_params(flipped, m, false)).id));
  }
}

TEMPLATE_TEST_CASE("y_up: the nvdiffrast G-buffer and its adjoint are y_up = false's on negated clip",
                   "[barycentric][y_up]", float, double) {
  using T = TestType;
  unsigned seed = 20;
  for (const Mesh& m : scenes()) {
    const std::vector<T> clip = as<T>(m.clip), flipped = negated_y(clip);
    const GBuffer<T> g = rasterize(raster_params(clip, m, true));
    const std::int64_t N = static_cast<std::int64_t>(clip.size() / 4), M = static_cast<std::int64_t>(m.tris.size() / 3);
    const BarycentricGBufferParams<T> up_p{clip.data(), N, m.tris.data(), M, W, H, true};
    const BarycentricGBufferParams<T> ref_p{flipped.data(), N, m.tris.data(), M, W, H, false};
    const BarycentricGBufferParams<T> plain_p{clip.data(), N, m.tris.data(), M, W, H, false};
    std::vector<T> rast(4 * P), db(4 * P), rast_ref(4 * P), db_ref(4 * P), rast_plain(4 * P), db_plain(4 * P);
    barycentric_gbuffer_forward(up_p, g.id.data(), 0, rast.data(), db.data());
    barycentric_gbuffer_forward(ref_p, g.id.data(), 0, rast_ref.data(), db_ref.data());
    barycentric_gbuffer_forward(plain_p, g.id.data(), 0, rast_plain.data(), db_plain.data());
    REQUIRE(same_bits(rast, rast_ref));
    REQUIRE(same_bits(db, db_ref));
    REQUIRE_FALSE(same_bits(db, db_plain));

    const std::vector<T> g_rast = random_t<T>(4 * P, ++seed), g_db = random_t<T>(4 * P, ++seed);
    const std::vector<T> start = random_t<T>(clip.size(), ++seed);
    std::vector<T> up = start, ref = negated_y(start), plain = start;
    barycentric_gbuffer_backward(up_p, rast.data(), g_rast.data(), g_db.data(), up.data());
    barycentric_gbuffer_backward(ref_p, rast.data(), g_rast.data(), g_db.data(), ref.data());
    barycentric_gbuffer_backward(plain_p, rast.data(), g_rast.data(), g_db.data(), plain.data());
    REQUIRE(same_bits(up, negated_y(ref)));
    REQUIRE_FALSE(same_bits(up, plain));
  }
}

TEMPLATE_TEST_CASE("y_up: antialias and visibility_antialias and their adjoints are y_up = false's on negated clip",
                   "[antialias][visibility_antialias][y_up]", float, double) {
  using T = TestType;
  unsigned seed = 30;
  constexpr int C = 2;
  for (const Mesh& m : scenes()) {
    const std::vector<T> clip = as<T>(m.clip), flipped = negated_y(clip);
    const std::int64_t N = static_cast<std::int64_t>(clip.size() / 4), M = static_cast<std::int64_t>(m.tris.size() / 3);
    const EdgeTopology topology = build_edge_topology(m.tris.data(), M, N);
    const GBuffer<T> g = rasterize(raster_params(clip, m, true));
    const std::vector<T> image = random_t<T>(C * P, ++seed), g_out = random_t<T>(C * P, ++seed);
    auto params = [&](const std::vector<T>& c, bool y_up) {
      AntialiasParams<T> p;
      p.image = image.data();
      p.channels = C;
      p.width = W;
      p.height = H;
      p.tri_id = g.id.data();
      p.depth = g.depth.data();
      p.clip = c.data();
      p.num_vertices = N;
      p.tris = m.tris.data();
      p.num_tris = M;
      p.topology = &topology;
      p.y_up = y_up;
      return p;
    };
    for (bool visibility : {false, true}) {
      std::vector<T> out(C * P), out_ref(C * P), out_plain(C * P);
      BlendedPairs pairs, pairs_ref, pairs_plain;
      blend_boundaries_forward(visibility, params(clip, true), out.data(), &pairs);
      blend_boundaries_forward(visibility, params(flipped, false), out_ref.data(), &pairs_ref);
      blend_boundaries_forward(visibility, params(clip, false), out_plain.data(), &pairs_plain);
      REQUIRE(same_bits(out, out_ref));
      REQUIRE(pairs.silhouette.size() + pairs.boundary.size() > 0);
      REQUIRE_FALSE(same_bits(out, out_plain));

      const std::vector<T> start_image = random_t<T>(C * P, ++seed), start_clip = random_t<T>(clip.size(), ++seed);
      std::vector<T> gi = start_image, gi_ref = start_image, gi_plain = start_image;
      std::vector<T> gc = start_clip, gc_ref = negated_y(start_clip), gc_plain = start_clip;
      blend_boundaries_backward(params(clip, true), pairs, g_out.data(), AntialiasGrads<T>{gi.data(), gc.data()});
      blend_boundaries_backward(params(flipped, false), pairs_ref, g_out.data(),
                                AntialiasGrads<T>{gi_ref.data(), gc_ref.data()});
      blend_boundaries_backward(params(clip, false), pairs, g_out.data(),
                                AntialiasGrads<T>{gi_plain.data(), gc_plain.data()});
      REQUIRE(same_bits(gi, gi_ref));
      REQUIRE(same_bits(gc, negated_y(gc_ref)));
      REQUIRE_FALSE(same_bits(gc, gc_plain));
    }
  }
}

TEST_CASE("y_up: screen_to_clip_backward is y_up = false's on negated clip, its y negated back", "[project][y_up]") {
  const std::vector<double> clip = testing::random_vector(4 * 50, 0.2, 1.5, 41);
  const std::vector<double> g_screen = testing::random_vector(3 * 50, -1, 1, 42);
  const std::vector<double> start = testing::random_vector(4 * 50, -1, 1, 43);
  std::vector<float> up = as<float>(start), ref = negated_y(as<float>(start)), plain = as<float>(start);
  const std::vector<float> c = as<float>(clip), flipped = negated_y(c);
  screen_to_clip_backward(c.data(), 50, W, H, g_screen.data(), 3, up.data(), true);
  screen_to_clip_backward(flipped.data(), 50, W, H, g_screen.data(), 3, ref.data(), false);
  screen_to_clip_backward(c.data(), 50, W, H, g_screen.data(), 3, plain.data(), false);
  REQUIRE(same_bits(up, negated_y(ref)));
  REQUIRE_FALSE(same_bits(up, plain));
}

TEST_CASE("y_up: culling judges the mirrored triangle, so Back drops faces counter-clockwise in NDC",
          "[rasterize][y_up]") {
  const Mesh ccw{{-0.5, -0.5, 0.0, 1.0, 0.8, -0.5, 0.0, 1.0, -0.5, 0.8, 0.0, 1.0}, {0, 1, 2}};
  auto covered = [&](bool y_up, Cull cull) {
    const GBuffer<double> g = rasterize(raster_params(ccw.clip, ccw, y_up, cull));
    std::int64_t n = 0;
    for (std::int32_t id : g.id) n += id != 0;
    return n;
  };
  REQUIRE(covered(false, Cull::Back) > 100);  // OpenGL's front face
  REQUIRE(covered(false, Cull::Front) == 0);
  REQUIRE(covered(true, Cull::Back) == 0);
  REQUIRE(covered(true, Cull::Front) == covered(false, Cull::Back));
}
