// The surface walk shared by antialias and visibility_antialias
// (raster/detail/surface_walk.h): the walk's three outcomes on a two-triangle quad,
// the memo of surface sides, the neighbour-pair scan and the one-sided blend step.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <vector>

#include "raster/detail/surface_walk.h"

using namespace gr::raster;
using namespace gr::raster::detail;

namespace {

// A quad of clip x, y in [-0.5, 0.5] at w = 1, split along its diagonal into
// triangle 0 (lower left) and triangle 1 (upper right), on a 10 x 10 screen
// (pixels 2.5 .. 7.5 covered).
struct Quad {
  std::vector<float> clip{-0.5f, -0.5f, 0.f, 1.f, 0.5f, -0.5f, 0.f, 1.f, 0.5f, 0.5f, 0.f, 1.f, -0.5f, 0.5f, 0.f, 1.f};
  std::vector<std::int32_t> tris{0, 1, 2, 0, 2, 3};
  Vertices v = project_vertices(clip.data(), 4, 10, 10);
  EdgeTopology topology = build_edge_topology(tris.data(), 2, 4);
};

}  // namespace

TEST_CASE("surface walk: crossing the shared diagonal reaches the other triangle, the quad's border is a silhouette",
          "[raster][antialias][surface_walk]") {
  const Quad q;
  // Screen: x right, y down; triangle 0 = (2.5, 7.5), (7.5, 7.5), (7.5, 2.5) (lower right of the diagonal).
  const WalkEnd reached = walk_surface(q.v, q.tris.data(), q.topology, 10, 10, 0, 1, 6.5, 6.5, 3.5, 3.5);
  CHECK(reached.kind == WalkEnd::Kind::Reached);
  // From inside triangle 0 out through its bottom edge (y = 7.5) at a quarter of the segment.
  const WalkEnd out = walk_surface(q.v, q.tris.data(), q.topology, 10, 10, 0, -1, 5.0, 7.0, 5.0, 9.0);
  REQUIRE(out.kind == WalkEnd::Kind::Silhouette);
  CHECK(out.t == Approx(0.25));
  CHECK(((out.a == 0 && out.b == 1) || (out.a == 1 && out.b == 0)));
  // Both centres on the quad, target elsewhere: the surface continues.
  const WalkEnd on = walk_surface(q.v, q.tris.data(), q.topology, 10, 10, 0, 7, 6.5, 6.5, 3.5, 3.5);
  CHECK(on.kind == WalkEnd::Kind::Continues);
}

TEST_CASE("surface walk: a memo of the surface sides gives the ends and paths of no memo, bit for bit",
          "[raster][antialias][surface_walk]") {
  // A 9 x 9 vertex grid, jittered in x, y and w so that some triangles fold
  // over (silhouettes inside the mesh), on a 24 x 24 screen.
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> jitter(-0.12f, 0.12f), wj(0.8f, 1.2f);
  const int n = 9, size = 24;
  std::vector<float> clip;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float w = wj(rng);
      const float x = -0.9f + 1.8f * i / (n - 1) + jitter(rng), y = -0.9f + 1.8f * j / (n - 1) + jitter(rng);
      clip.insert(clip.end(), {x * w, y * w, 0.f, w});
    }
  std::vector<std::int32_t> tris;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::int32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      tris.insert(tris.end(), {a, b, d, a, d, c});
    }
  const std::int64_t m = static_cast<std::int64_t>(tris.size() / 3);
  const Vertices v = project_vertices(clip.data(), n * n, size, size);
  const EdgeTopology topology = build_edge_topology(tris.data(), m, n * n);
  SurfaceSides sides(m);
  std::uniform_int_distribution<std::int64_t> tri(0, m - 1);
  std::uniform_real_distribution<double> at(0.0, size);
  int silhouettes = 0;
  for (int round = 0; round < 2; ++round) {  // the second round reads what the first stored
    std::mt19937 segments(7);
    for (int k = 0; k < 2000; ++k) {
      const std::int64_t start = tri(segments), target = k % 3 == 0 ? tri(segments) : -1;
      const double cix = at(segments), ciy = at(segments), cox = at(segments), coy = at(segments);
      WalkPath plain_path, memo_path;
      const WalkEnd plain = walk_surface(v, tris.data(), topology, size, size, start, target, cix, ciy, cox, coy,
                                         &plain_path);
      const WalkEnd memo = walk_surface(v, tris.data(), topology, size, size, start, target, cix, ciy, cox, coy,
                                        &memo_path, &sides);
      REQUIRE(memo.kind == plain.kind);
      REQUIRE(memo.a == plain.a);
      REQUIRE(memo.b == plain.b);
      REQUIRE(std::memcmp(&memo.t, &plain.t, sizeof plain.t) == 0);
      REQUIRE(memo_path.count == plain_path.count);
      for (int i = 0; i < plain_path.count; ++i) {
        REQUIRE(memo_path.tri[i] == plain_path.tri[i]);
        REQUIRE(std::memcmp(&memo_path.t[i], &plain_path.t[i], sizeof(double)) == 0);
      }
      silhouettes += plain.kind == WalkEnd::Kind::Silhouette;
    }
  }
  CHECK(silhouettes > 100);  // the walks do end at silhouettes, not only at the centres
}

TEST_CASE("surface walk: the pair scan visits each differing right and lower neighbour once",
          "[raster][antialias][surface_walk]") {
  // 3 x 2 ids 1 1 2 / 1 0 2: pixels 1-2 (right), 1-4 (down), 3-4 and 4-5 (right) differ.
  const std::vector<std::int32_t> ids{1, 1, 2, 1, 0, 2};
  struct Pair {
    std::int64_t p, q;
    bool horizontal;
  };
  std::vector<std::vector<Pair>> rows;
  const std::int64_t count = for_each_id_boundary(ids.data(), 3, 2, rows, [](std::int64_t p, std::int64_t q, bool h,
                                                                            std::vector<Pair>& row) {
    row.push_back({p, q, h});
  });
  CHECK(count == 4);
  REQUIRE(rows.size() == 2);
  REQUIRE(rows[0].size() == 2);
  CHECK((rows[0][0].p == 1 && rows[0][0].q == 2 && rows[0][0].horizontal));
  CHECK((rows[0][1].p == 1 && rows[0][1].q == 4 && !rows[0][1].horizontal));
  REQUIRE(rows[1].size() == 2);
  CHECK((rows[1][0].p == 3 && rows[1][0].q == 4));
  CHECK((rows[1][1].p == 4 && rows[1][1].q == 5));
}

TEST_CASE("surface walk: the blend step moves the far-side pixel by |t - 1/2| of the other's colour",
          "[raster][antialias][surface_walk]") {
  struct Pair {
    std::int64_t inside, outside;
    double t;
  };
  const BlendStep out = blend_step(Pair{3, 4, 0.8});
  CHECK((out.target == 4 && out.source == 3));
  CHECK(out.w == Approx(0.3));
  const BlendStep in = blend_step(Pair{3, 4, 0.1});
  CHECK((in.target == 3 && in.source == 4));
  CHECK(in.w == Approx(0.4));
  const std::vector<double> image{0, 0, 0, 1.0, 3.0};
  std::vector<double> blended = image;
  apply_blend(out, image.data(), blended.data(), 1);
  CHECK(blended[4] == Approx(3.0 + 0.3 * (1.0 - 3.0)));
}
