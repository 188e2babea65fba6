// classify_lanes and lane_fragments (raster/detail/classify_lanes.h) against the
// scalar rules they batch: classify_triangle's class and box for every
// triangle, NoPixel exactly where no centre of a small box is covered, and,
// for the others, the fragments the per-pixel rule gives (setup_edges, the
// edge values and the depth range test of the tile scan), bit for bit; on
// random triangles of every size, on vertices and edges through pixel centres
// (the top-left rule's ties), degenerate, culled, off-screen and near-plane
// triangles, and batches shorter than the lanes.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <vector>

#include "raster/detail/classify_lanes.h"
#include "raster/pixel_rule.h"

using namespace gr::raster::detail;

namespace {

constexpr int W = 37, H = 29, kTilesX = (W + kTile - 1) / kTile;

// The per-pixel rule over a small box, row by row: the fragments of the
// covered centres that pass the depth range test; `covered` counts the
// covered centres before that test.
std::vector<Fragment> reference_fragments(const Vertices& v, const std::int32_t* tris, std::int32_t t,
                                          const PixelBox& b, int* covered) {
  TriSetup s;
  setup_edges(v, tris + 3 * t, W, H, &s);
  std::vector<Fragment> out;
  *covered = 0;
  for (int y = b.y0; y <= b.y1; ++y)
    for (int x = b.x0; x <= b.x1; ++x) {
      double e[3];
      if (!gr::testing::covers_centre(s, x, y, e)) continue;
      ++*covered;
      const double z = gr::testing::centre_depth(s, e);
      if (!gr::testing::in_depth_range(s, z)) continue;
      const int where = ((y / kTile) * kTilesX + x / kTile) * kTilePixels + (y % kTile) * kTile + x % kTile;
      out.push_back({z, e[1] * s.e[1].mu, e[2] * s.e[2].mu, t, where});
    }
  return out;
}

bool same_bits(const Fragment& a, const Fragment& b) {
  return std::memcmp(&a.z, &b.z, sizeof a.z) == 0 && std::memcmp(&a.u, &b.u, sizeof a.u) == 0 &&
         std::memcmp(&a.v, &b.v, sizeof a.v) == 0 && a.id == b.id && a.where == b.where;
}

// Compares every triangle, in batches of `batch` (the last one shorter).
void check_all(const std::vector<float>& clip, const std::vector<std::int32_t>& tris, int batch) {
  const Vertices v = project_vertices(clip.data(), static_cast<std::int64_t>(clip.size() / 4), W, H);
  const std::int64_t n = static_cast<std::int64_t>(tris.size() / 3);
  int counts[6] = {}, fragments = 0;
  for (int cull : {0, 1, -1})
    for (std::int64_t t0 = 0; t0 < n; t0 += batch) {
      const int m = static_cast<int>(std::min<std::int64_t>(batch, n - t0));
      TriClass k[kClassifyLanes];
      PixelBox box[kClassifyLanes];
      LaneCoverage cover;
      classify_lanes(v, tris.data(), t0, m, W, H, cull, k, box, &cover);
      for (int i = 0; i < m; ++i) {
        const std::int64_t t = t0 + i;
        const std::int32_t* tri = tris.data() + 3 * t;
        INFO("triangle " << t << ", cull " << cull);
        // Left to classify_triangle: crossing the near plane, not outside a frustum plane.
        if (!(v.outcode[tri[0]] & v.outcode[tri[1]] & v.outcode[tri[2]]) && needs_clipping(v, tri)) {
          REQUIRE(k[i] == TriClass::Clipped);
          ++counts[static_cast<int>(TriClass::Clipped)];
          continue;
        }
        PixelBox b{};
        TriClass want = classify_triangle(v, tri, W, H, cull, &b);
        const bool small = want == TriClass::Raster && (b.x1 - b.x0 + 1) * (b.y1 - b.y0 + 1) <= kMaxFragmentBox;
        int covered = 0;
        const std::vector<Fragment> ref =
            small ? reference_fragments(v, tris.data(), static_cast<std::int32_t>(t), b, &covered) : std::vector<Fragment>();
        if (small && covered == 0) want = TriClass::NoPixel;
        REQUIRE(static_cast<int>(k[i]) == static_cast<int>(want));
        ++counts[static_cast<int>(want)];
        if (want != TriClass::Raster) continue;
        CHECK((box[i].x0 == b.x0 && box[i].x1 == b.x1 && box[i].y0 == b.y0 && box[i].y1 == b.y1));
        if (!small) continue;
        Fragment f[kMaxFragmentBox];
        const int emitted = lane_fragments(v, tris.data(), static_cast<std::int32_t>(t), box[i], cover, i, kTilesX, f);
        REQUIRE(emitted == static_cast<int>(ref.size()));
        for (int j = 0; j < emitted; ++j) CHECK(same_bits(f[j], ref[j]));
        fragments += emitted;
      }
    }
  // Every class occurs, so each branch of the comparison ran, and fragments were compared.
  for (int c = 0; c < 6; ++c) CHECK(counts[c] > 0);
  CHECK(fragments > 100);
}

// Clip coordinates of a screen point (sx, sy) at depth z_ndc and w.
void add_vertex(std::vector<float>& clip, double sx, double sy, double z, double w) {
  clip.push_back(static_cast<float>((2.0 * sx / W - 1.0) * w));
  clip.push_back(static_cast<float>((1.0 - 2.0 * sy / H) * w));
  clip.push_back(static_cast<float>(z * w));
  clip.push_back(static_cast<float>(w));
}

}  // namespace

TEST_CASE("classify_lanes gives the scalar class and box of random triangles of every size") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-6.0, W + 6.0), size(0.0, 1.0), z(-0.9, 1.2), w(0.5, 3.0);
  std::vector<float> clip;
  std::vector<std::int32_t> tris;
  for (int t = 0; t < 3000; ++t) {
    const double cx = pos(rng), cy = pos(rng);
    // Mostly boxes of a few centres (the lanes' own coverage test), some large.
    const double r = t % 5 == 0 ? 8.0 * size(rng) : 1.6 * size(rng);
    for (int c = 0; c < 3; ++c) {
      add_vertex(clip, cx + r * (size(rng) - 0.5), cy + r * (size(rng) - 0.5), z(rng), w(rng));
      tris.push_back(static_cast<std::int32_t>(tris.size()));
    }
  }
  // Some near-plane crossings and some zero areas (a vertex repeated).
  for (int t = 0; t < 60; ++t) {
    add_vertex(clip, pos(rng), pos(rng), t % 2 ? -1.5 : 0.0, t % 3 ? 1.0 : -0.5);
    tris.push_back(static_cast<std::int32_t>(clip.size() / 4 - 1));
    tris.push_back(static_cast<std::int32_t>(rng() % 9000));
    tris.push_back(t % 4 ? static_cast<std::int32_t>(rng() % 9000) : tris[tris.size() - 1]);
  }
  for (int batch : {kClassifyLanes, 5, 1}) check_all(clip, tris, batch);
}

TEST_CASE("classify_lanes settles centres on edges and vertices as the top-left rule does") {
  // Vertices on a grid of half pixels: edges through centres, horizontal and
  // vertical edges, vertices on centres, shared edges in both index orders.
  std::mt19937 rng(11);
  std::vector<float> clip;
  for (int j = 0; j <= 2 * H; ++j)
    for (int i = 0; i <= 2 * W; ++i) add_vertex(clip, 0.5 * i, 0.5 * j, 0.25, 1.0);
  const std::int32_t per_row = 2 * W + 1, count = per_row * (2 * H + 1);
  std::vector<std::int32_t> tris;
  for (int t = 0; t < 4000; ++t) {
    const std::int32_t a = static_cast<std::int32_t>(rng() % count);
    const int di = static_cast<int>(rng() % 5), dj = static_cast<int>(rng() % 5);
    const std::int32_t b = std::min(count - 1, a + di), c = std::min(count - 1, a + dj * per_row + di % 3);
    tris.insert(tris.end(), {a, b, c});
  }
  // Slivers covering only the last centre of a box one column wide and four
  // rows tall (slot 3: row 3), of a box four wide (column 3), and of a 2 x 2
  // box (row 1, column 1); both windings.
  const double slivers[][6] = {{2.3, 0.2, 2.35, 3.8, 2.6, 3.8},
                               {0.2, 2.3, 3.8, 2.35, 3.8, 2.6},
                               {0.3, 0.3, 1.45, 1.8, 1.8, 1.45}};
  for (const auto& q : slivers) {
    const std::int32_t first = static_cast<std::int32_t>(clip.size() / 4);
    for (int c = 0; c < 3; ++c) add_vertex(clip, q[2 * c], q[2 * c + 1], 0.25, 1.0);
    tris.insert(tris.end(), {first, first + 1, first + 2, first, first + 2, first + 1});
  }
  // Vertices outside the frustum (w < 0) and behind the near plane, for the other classes.
  const std::int32_t behind = static_cast<std::int32_t>(clip.size() / 4);
  add_vertex(clip, 3.0, 3.0, -2.0, 1.0);
  add_vertex(clip, 5.0, 3.0, -2.0, 1.0);
  add_vertex(clip, 3.0, 5.0, -2.0, 1.0);
  tris.insert(tris.end(), {behind, behind + 1, behind + 2});
  tris.insert(tris.end(), {behind, 0, per_row + 3});
  for (int batch : {kClassifyLanes, 3}) check_all(clip, tris, batch);
}
