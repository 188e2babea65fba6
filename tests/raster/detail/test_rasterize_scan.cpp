// The rasterizer's tile scan (raster/detail/rasterize_scan.h) against the plain
// per-pixel loop its header documents: same coverage, depth, ids and (u, v),
// bit for bit, on the vector path (wide boxes, odd widths, clipped to the
// tile), the small-box path, pixel-centre ties and near-plane triangles.
#include <catch2/catch.hpp>

#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "raster/pixel_rule.h"
#include "raster/detail/rasterize_scan.h"

using namespace gr::raster::detail;

namespace {

void clear(TileBuffer& tb) {
  for (int p = 0; p < kTilePixels; ++p) {
    tb.z[p] = std::numeric_limits<double>::infinity();
    tb.id[p] = -1;
    tb.u[p] = tb.v[p] = 0.0;
  }
  tb.covered = 0;
  tb.zmax = std::numeric_limits<double>::infinity();
}

// The documented per-pixel rule, one pixel at a time.
void reference_scan(const Vertices& v, const std::int32_t* tris, std::int32_t t, const PixelBox& b, int tx0,
                    int ty0, int tx1, int ty1, int width, int height, TileBuffer& tb) {
  TriSetup s;
  setup_edges(v, tris + 3 * t, width, height, &s);
  for (int y = std::max(b.y0, ty0); y <= std::min(b.y1, ty1); ++y)
    for (int x = std::max(b.x0, tx0); x <= std::min(b.x1, tx1); ++x) {
      double e[3];
      if (!gr::testing::covers_centre(s, x, y, e)) continue;
      const double z = gr::testing::centre_depth(s, e);
      if (!gr::testing::in_depth_range(s, z)) continue;
      const int p = (y - ty0) * kTile + (x - tx0);
      if (z < tb.z[p] || (z == tb.z[p] && t < tb.id[p])) {
        tb.covered += tb.id[p] < 0;
        tb.z[p] = z;
        tb.id[p] = t;
        tb.u[p] = e[1] * s.e[1].mu;
        tb.v[p] = e[2] * s.e[2].mu;
      }
    }
}

bool same_bits(const TileBuffer& a, const TileBuffer& b) {
  return std::memcmp(a.z, b.z, sizeof a.z) == 0 && std::memcmp(a.u, b.u, sizeof a.u) == 0 &&
         std::memcmp(a.v, b.v, sizeof a.v) == 0 && std::memcmp(a.id, b.id, sizeof a.id) == 0 &&
         a.covered == b.covered;
}

}  // namespace

TEST_CASE("rasterize scan: every tile equals the plain per-pixel loop bit for bit", "[raster][rasterize]") {
  const int W = 77, H = 45;  // odd sizes: partial tiles and odd row lengths
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ndc(-1.3, 1.3), depth(-0.9, 0.9), size(0.002, 1.5);
  std::vector<double> clip;
  auto vertex = [&](double x, double y, double z, double w) { clip.insert(clip.end(), {x * w, y * w, z * w, w}); };
  for (int t = 0; t < 300; ++t) {
    // Triangles from sub-pixel to larger than the image, some with vertices
    // exactly on pixel centres (edge values of exactly 0: the tie rule).
    const double cx = ndc(rng), cy = ndc(rng), r = size(rng);
    const bool on_centres = t % 5 == 0;
    for (int k = 0; k < 3; ++k) {
      double x = cx + r * ndc(rng), y = cy + r * ndc(rng);
      if (on_centres) {
        x = (std::floor((x + 1) * W / 2) + 0.5) * 2 / W - 1;
        y = 1 - (std::floor((1 - y) * H / 2) + 0.5) * 2 / H;
      }
      vertex(x, y, depth(rng), 0.5 + 2.0 * (k + t % 3) / 4);
    }
  }
  // Two triangles crossing the near plane (homogeneous setup).
  clip.insert(clip.end(), {-0.5, -0.5, 0.2, 1.0, 0.6, -0.4, -0.3, 0.2, 0.1, 0.7, -1.2, -0.5});
  clip.insert(clip.end(), {0.9, 0.9, 0.0, 1.0, -0.9, 0.2, 0.1, 0.8, 0.0, -0.8, -0.5, 0.0});
  const std::int32_t num_vertices = static_cast<std::int32_t>(clip.size() / 4);
  std::vector<std::int32_t> tris(num_vertices);
  for (std::int32_t i = 0; i < num_vertices; ++i) tris[i] = i;
  const Vertices v = project_vertices(clip.data(), num_vertices, W, H);

  int scanned = 0, clipped = 0;
  for (int ty0 = 0; ty0 < H; ty0 += kTile)
    for (int tx0 = 0; tx0 < W; tx0 += kTile) {
      const int tx1 = std::min(W, tx0 + kTile) - 1, ty1 = std::min(H, ty0 + kTile) - 1;
      TileBuffer fast, plain;
      clear(fast);
      clear(plain);
      for (std::int32_t t = 0; t < num_vertices / 3; ++t) {
        PixelBox b;
        const TriClass k = classify_triangle(v, &tris[3 * t], W, H, 0, &b);
        if (k != TriClass::Raster && k != TriClass::Clipped) continue;
        ++scanned;
        clipped += k == TriClass::Clipped;
        scan_triangle(v, tris.data(), t, b, tx0, ty0, tx1, ty1, W, H, fast);
        reference_scan(v, tris.data(), t, b, tx0, ty0, tx1, ty1, W, H, plain);
      }
      INFO("tile at " << tx0 << ", " << ty0);
      CHECK(plain.covered > 0);
      CHECK(same_bits(fast, plain));
    }
  CHECK(clipped > 0);
  CHECK(scanned > 200);
}
