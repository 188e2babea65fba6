// The antialias walk's prefilter (raster/detail/silhouette_mask.h): with it
// forced on, antialias_forward finds the same pairs, blends and gradients bit
// for bit as with it off, on random vertex soups (folds, non-manifold edges),
// icospheres (up to 20480 triangles at 512 x 448), jittered planes and
// spheres, open meshes, welded topologies, near-plane clipping and y_up,
// at any thread count; and it does skip walks where it can.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/antialias.h"
#include "raster/detail/silhouette_mask.h"
#include "raster/procedural.h"
#include "raster/rasterize.h"

using namespace gr;
using namespace gr::raster;

namespace rd = gr::raster::detail;

namespace {

struct Scene {
  std::vector<double> clip;  // N x 4
  std::vector<std::int32_t> tris;
  bool weld = false;  // topology welded by clip rows
};

struct Run {
  std::vector<double> out, grad_clip, grad_image;
  std::vector<AntialiasPair> pairs;
  AntialiasStats stats;
};

// Restores the prefilter mode and the thread count when a test ends.
struct ModeGuard {
  ~ModeGuard() {
    rd::g_silhouette_prefilter = rd::SilhouettePrefilter::Auto;
    set_num_threads(0);
  }
};

Run antialias_with(const Scene& s, int W, int H, bool y_up, rd::SilhouettePrefilter mode) {
  const std::int64_t n = static_cast<std::int64_t>(s.clip.size() / 4), m = static_cast<std::int64_t>(s.tris.size() / 3);
  const std::int64_t P = std::int64_t(W) * H;
  std::vector<std::int32_t> tri_id(P);
  std::vector<double> uv(2 * P), depth(P);
  RasterSettings settings{W, H};
  settings.y_up = y_up;
  rasterize_forward(RasterParams<double>{s.clip.data(), n, s.tris.data(), m, settings}, tri_id.data(), uv.data(),
                    depth.data());
  const int C = 2;
  std::vector<double> image(P * C);
  for (std::int64_t p = 0; p < P; ++p)
    for (int c = 0; c < C; ++c) image[p * C + c] = std::sin(0.37 * tri_id[p] + 1.3 * c) + 0.01 * c * (p % 7);
  const EdgeTopology topo = s.weld ? build_edge_topology(s.tris.data(), m, n, s.clip.data(), 4)
                                   : build_edge_topology(s.tris.data(), m, n);
  AntialiasParams<double> prm;
  prm.image = image.data();
  prm.channels = C;
  prm.width = W;
  prm.height = H;
  prm.tri_id = tri_id.data();
  prm.depth = depth.data();
  prm.clip = s.clip.data();
  prm.num_vertices = n;
  prm.tris = s.tris.data();
  prm.num_tris = m;
  prm.topology = &topo;
  prm.y_up = y_up;
  Run r;
  r.out.resize(P * C);
  rd::g_silhouette_prefilter = mode;
  antialias_forward(prm, r.out.data(), &r.pairs, &r.stats);
  rd::g_silhouette_prefilter = rd::SilhouettePrefilter::Auto;
  std::vector<double> grad_out(P * C);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> g(-1.0, 1.0);
  for (double& x : grad_out) x = g(rng);
  r.grad_clip.assign(4 * n, 0.0);
  r.grad_image.assign(P * C, 0.0);
  antialias_backward(prm, r.pairs, grad_out.data(), AntialiasGrads<double>{r.grad_image.data(), r.grad_clip.data()});
  return r;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

bool same_pairs(const std::vector<AntialiasPair>& a, const std::vector<AntialiasPair>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].inside != b[i].inside || a[i].outside != b[i].outside || a[i].a != b[i].a || a[i].b != b[i].b ||
        std::memcmp(&a[i].t, &b[i].t, sizeof(double)) != 0)
      return false;
  return true;
}

// Prefiltered against unfiltered; returns how many walks the prefilter skipped.
std::int64_t check_identical(const Scene& s, int W, int H, bool y_up = false) {
  const Run plain = antialias_with(s, W, H, y_up, rd::SilhouettePrefilter::Never);
  const std::int64_t before = rd::g_prefilter_skipped_walks.load();
  const Run filtered = antialias_with(s, W, H, y_up, rd::SilhouettePrefilter::Always);
  const std::int64_t skipped = rd::g_prefilter_skipped_walks.load() - before;
  CHECK(same_pairs(plain.pairs, filtered.pairs));
  CHECK(same_bits(plain.out, filtered.out));
  CHECK(same_bits(plain.grad_clip, filtered.grad_clip));
  CHECK(same_bits(plain.grad_image, filtered.grad_image));
  CHECK(plain.stats.candidate_pairs == filtered.stats.candidate_pairs);
  CHECK(plain.stats.blended_pairs == filtered.stats.blended_pairs);
  return skipped;
}

// A mesh's positions seen by a camera at distance `dist` on +z looking at the
// origin (clip w = dist - z), rotated by `angle` about y and x.
Scene view_of(const Mesh& mesh, double dist, double angle, double scale = 1.0) {
  Scene s;
  const float* p = mesh.positions.data<float>();
  const std::int64_t n = mesh.num_vertices();
  const double c = std::cos(angle), sn = std::sin(angle);
  for (std::int64_t i = 0; i < n; ++i) {
    const double x0 = p[3 * i], y0 = p[3 * i + 1], z0 = p[3 * i + 2];
    const double x1 = c * x0 + sn * z0, z1 = -sn * x0 + c * z0;
    const double y = c * y0 - sn * z1, z = sn * y0 + c * z1;
    const double w = dist - z;
    s.clip.insert(s.clip.end(), {scale * x1, scale * y, 0.5 * w - 0.1, w});
  }
  const std::int32_t* t = mesh.triangles.data<std::int32_t>();
  s.tris.assign(t, t + 3 * mesh.num_triangles());
  return s;
}

// Random triangles over a small vertex pool: folds, overlaps, non-manifold edges.
Scene soup(std::uint32_t seed, int vertices, int triangles) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.1, 1.1), wz(1.0, 3.0);
  Scene s;
  for (int i = 0; i < vertices; ++i) {
    const double w = wz(rng);
    s.clip.insert(s.clip.end(), {u(rng) * w, u(rng) * w, 0.3 * w, w});
  }
  std::uniform_int_distribution<int> pick(0, vertices - 1);
  for (int t = 0; t < triangles; ++t) {
    int a = pick(rng), b = pick(rng), c = pick(rng);
    while (b == a) b = pick(rng);
    while (c == a || c == b) c = pick(rng);
    s.tris.insert(s.tris.end(), {a, b, c});
  }
  return s;
}

// Every triangle with vertices of its own (the topology must weld them).
Scene split(const Scene& s) {
  Scene out;
  out.weld = true;
  for (std::size_t k = 0; k < s.tris.size(); ++k) {
    const std::int32_t i = s.tris[k];
    out.clip.insert(out.clip.end(), s.clip.begin() + 4 * i, s.clip.begin() + 4 * i + 4);
    out.tris.push_back(static_cast<std::int32_t>(k));
  }
  return out;
}

}  // namespace

TEST_CASE("silhouette prefilter: antialias of a fine icosphere is bit for bit the unfiltered one and skips most walks",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  const Scene s = view_of(make_icosphere(4), 3.0, 0.4);
  const std::int64_t skipped = check_identical(s, 160, 120);
  CHECK(skipped > 0);
  CHECK(check_identical(s, 97, 61, true) > 0);
  CHECK(check_identical(view_of(make_icosphere(2), 2.2, 1.1), 31, 37) >= 0);
  CHECK(check_identical(view_of(make_icosphere(5), 2.8, 2.3), 512, 448) > 0);
}

TEST_CASE("silhouette prefilter: random vertex soups with folds and non-manifold edges give the unfiltered result",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  for (std::uint32_t seed = 1; seed <= 12; ++seed) {
    INFO("seed " << seed);
    const Scene s = soup(seed, 6 + 3 * static_cast<int>(seed), 8 + 5 * static_cast<int>(seed));
    check_identical(s, 48 + static_cast<int>(seed), 40, seed % 2 == 0);
    check_identical(split(s), 33, 29 + static_cast<int>(seed));
  }
}

TEST_CASE("silhouette prefilter: open meshes, folded planes and welded topologies give the unfiltered result",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  // An icosphere with every fifth triangle removed: boundaries everywhere.
  Scene open = view_of(make_icosphere(3), 3.0, 0.9);
  std::vector<std::int32_t> kept;
  for (std::size_t t = 0; t < open.tris.size() / 3; ++t)
    if (t % 5 != 2) kept.insert(kept.end(), open.tris.begin() + 3 * t, open.tris.begin() + 3 * t + 3);
  open.tris = kept;
  CHECK(check_identical(open, 128, 96) > 0);
  // A plane whose vertices jitter so that neighbours fold over each other.
  Scene folded = view_of(make_plane(24, 24, 2.0f), 2.5, 0.3);
  std::mt19937 rng(3);
  std::normal_distribution<double> jitter(0.0, 0.04);
  for (std::size_t i = 0; i < folded.clip.size(); i += 4) folded.clip[i] += jitter(rng), folded.clip[i + 1] += jitter(rng);
  check_identical(folded, 120, 100);
  check_identical(folded, 120, 100, true);
  // Welded: the torus with split vertices, and the folded plane.
  check_identical(split(view_of(make_torus(24, 12), 3.0, 0.7)), 100, 80);
  check_identical(split(folded), 90, 70);
}

TEST_CASE("silhouette prefilter: jittered planes and spheres at several sizes and angles give the unfiltered result",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  for (std::uint32_t seed = 1; seed <= 24; ++seed) {
    INFO("seed " << seed);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> angle(0.0, 3.0), amount(0.0, 0.05);
    Scene s = view_of(seed % 2 ? make_plane(30, 20, 2.0f) : make_icosphere(3), 2.4, angle(rng));
    std::normal_distribution<double> jitter(0.0, amount(rng));
    for (std::size_t i = 0; i < s.clip.size(); i += 4)
      for (int d = 0; d < 3; ++d) s.clip[i + d] += jitter(rng);
    check_identical(s, 48 + static_cast<int>(seed * 37 % 160), 40 + static_cast<int>(seed * 29 % 150), seed % 3 == 0);
  }
}

TEST_CASE("silhouette prefilter: a mesh crossing the near plane is walked in full with the same result",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  // The camera inside the torus ring: some vertices behind the near plane.
  Scene s = view_of(make_torus(32, 16, 1.0f, 0.3f), 1.0, 0.2);
  bool behind = false;
  for (std::size_t i = 0; i < s.clip.size(); i += 4) behind |= s.clip[i + 2] < -s.clip[i + 3];
  REQUIRE(behind);
  CHECK(check_identical(s, 80, 64) == 0);
}

TEST_CASE("silhouette prefilter: a vertex just in front of the eye, far off screen, makes every pair walk",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  Scene s = view_of(make_icosphere(3), 3.0, 0.4);
  REQUIRE(check_identical(s, 96, 80) > 0);
  // One more triangle from the sphere's first two vertices to a point at w = 1e-12 (screen ~1e13 px).
  const std::int32_t far = static_cast<std::int32_t>(s.clip.size() / 4);
  s.clip.insert(s.clip.end(), {0.3, 0.2, 0.0, 1e-12});
  s.tris.insert(s.tris.end(), {0, 1, far});
  CHECK(check_identical(s, 96, 80) == 0);
}

TEST_CASE("silhouette prefilter: the prefiltered result is the same on 1, 3 and 8 threads",
          "[raster][antialias][silhouette_mask]") {
  ModeGuard guard;
  const Scene s = view_of(make_icosphere(4), 2.6, 0.5);
  set_num_threads(1);
  const Run one = antialias_with(s, 150, 130, false, rd::SilhouettePrefilter::Always);
  for (int threads : {3, 8}) {
    set_num_threads(threads);
    const Run many = antialias_with(s, 150, 130, false, rd::SilhouettePrefilter::Always);
    CHECK(same_pairs(one.pairs, many.pairs));
    CHECK(same_bits(one.out, many.out));
    CHECK(same_bits(one.grad_clip, many.grad_clip));
  }
}

TEST_CASE("silhouette prefilter: the per call choice follows the candidate pairs per triangle",
          "[raster][antialias][silhouette_mask]") {
  // Two rows of four pixels: ids 1 1 2 2 / 1 3 3 2 differ at 1 + 2 horizontal and 2 vertical pairs.
  const std::vector<std::int32_t> ids{1, 1, 2, 2, 1, 3, 3, 2};
  CHECK(rd::count_id_boundaries(ids.data(), 4, 2) == 5);
  CHECK(rd::prefilter_pays(1000, 100));
  CHECK_FALSE(rd::prefilter_pays(10, 100000));
}
