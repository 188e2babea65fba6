// Antialias kernels on plain arrays: edge topology (welding, boundaries,
// non-manifold edges), hand-computed blends across a straight silhouette, and
// no blending across interior or continuing edges.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"
#include "raster/antialias.h"
#include "raster/rasterize.h"

using namespace gr;
using namespace gr::raster;

namespace {

// Rasterizes clip (w = 1 rows given as x, y, z) at W x H and antialiases the
// image "1 on any triangle, 0 on background" (one channel).
struct Result {
  std::vector<std::int32_t> tri_id;
  std::vector<double> clip, image, out;
  std::vector<AntialiasPair> pairs;
  AntialiasStats stats;
};
Result render(const std::vector<double>& xyz, const std::vector<std::int32_t>& tris, int W, int H,
              const EdgeTopology* topo = nullptr) {
  const std::int64_t n = static_cast<std::int64_t>(xyz.size() / 3), m = static_cast<std::int64_t>(tris.size() / 3);
  Result r;
  std::vector<double>& clip = r.clip;
  for (std::int64_t i = 0; i < n; ++i) clip.insert(clip.end(), {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 1.0});
  const std::int64_t P = std::int64_t(W) * H;
  r.tri_id.resize(P);
  std::vector<double> uv(2 * P), depth(P);
  rasterize_forward(RasterParams<double>{clip.data(), n, tris.data(), m, RasterSettings{W, H}}, r.tri_id.data(),
                    uv.data(), depth.data());
  r.image.resize(P);
  for (std::int64_t p = 0; p < P; ++p) r.image[p] = r.tri_id[p] != 0 ? 1.0 : 0.0;
  r.out.resize(P);
  const EdgeTopology own = build_edge_topology(tris.data(), m, n, clip.data(), 4);
  AntialiasParams<double> p;
  p.image = r.image.data();
  p.channels = 1;
  p.width = W;
  p.height = H;
  p.tri_id = r.tri_id.data();
  p.depth = depth.data();
  p.clip = clip.data();
  p.num_vertices = n;
  p.tris = tris.data();
  p.num_tris = m;
  p.topology = topo ? topo : &own;
  antialias_forward(p, r.out.data(), &r.pairs, &r.stats);
  return r;
}

// NDC x of screen column position xs for width W.
double ndc_x(double xs, int W) { return 2.0 * xs / W - 1.0; }

// A straight silhouette through the W x H image: one large triangle whose edge
// 0-1 passes through screen point `centre` at `degrees` from vertical
// (direction d = (sin, cos), y down), moved by `shift` pixels along the normal
// n = (cos, -sin); the triangle covers the side n . (q - line) < 0.
struct HalfPlane {
  double cx, cy, nx, ny, dx, dy;
  std::vector<double> xyz;  // three vertices, NDC x, y, z = 0
};
HalfPlane half_plane(double degrees, double shift, int W, int H, double cx = 32.37, double cy = 31.81) {
  const double a = degrees * 3.14159265358979323846 / 180.0;
  HalfPlane h{cx + shift * std::cos(a), cy - shift * std::sin(a), std::cos(a), -std::sin(a), std::sin(a), std::cos(a),
              {}};
  const double far = 8.0 * (W + H);
  const double sx[3] = {h.cx - far * h.dx, h.cx + far * h.dx, h.cx - far * h.nx};
  const double sy[3] = {h.cy - far * h.dy, h.cy + far * h.dy, h.cy - far * h.ny};
  for (int k = 0; k < 3; ++k) h.xyz.insert(h.xyz.end(), {ndc_x(sx[k], W), 1.0 - 2.0 * sy[k] / H, 0.0});
  return h;
}

// Area of the unit pixel [x, x+1] x [y, y+1] on the side n . (q - c) < 0
// (Sutherland-Hodgman clip of the square by one half-plane, then the shoelace formula).
double covered_area(const HalfPlane& h, int x, int y) {
  const double sq[4][2] = {{double(x), double(y)}, {x + 1.0, double(y)}, {x + 1.0, y + 1.0}, {double(x), y + 1.0}};
  std::vector<std::array<double, 2>> poly;
  auto f = [&](const double* q) { return h.nx * (q[0] - h.cx) + h.ny * (q[1] - h.cy); };
  for (int k = 0; k < 4; ++k) {
    const double *p = sq[k], *q = sq[(k + 1) % 4];
    const double fp = f(p), fq = f(q);
    if (fp < 0) poly.push_back({p[0], p[1]});
    if ((fp < 0) != (fq < 0)) {
      const double t = fp / (fp - fq);
      poly.push_back({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])});
    }
  }
  double area = 0;
  for (std::size_t k = 0; k < poly.size(); ++k) {
    const auto& p = poly[k];
    const auto& q = poly[(k + 1) % poly.size()];
    area += p[0] * q[1] - q[0] * p[1];
  }
  return 0.5 * std::abs(area);
}

// Length of the half-plane's line inside the W x H image (Liang-Barsky clip).
double length_in_image(const HalfPlane& h, int W, int H) {
  double lo = -1e300, hi = 1e300;
  const double start[2] = {h.cx, h.cy}, dir[2] = {h.dx, h.dy}, size[2] = {double(W), double(H)};
  for (int i = 0; i < 2; ++i) {
    if (std::abs(dir[i]) < 1e-15) continue;  // parallel to this pair of borders (inside them here)
    double u0 = (0.0 - start[i]) / dir[i], u1 = (size[i] - start[i]) / dir[i];
    if (u0 > u1) std::swap(u0, u1);
    lo = std::max(lo, u0);
    hi = std::min(hi, u1);
  }
  return std::max(0.0, hi - lo);
}

// d(sum of the antialiased image)/d(shift) from the adjoint: grad_out = 1,
// grad_clip contracted with the vertices' motion (all three move by n pixels).
double adjoint_shift_rate(const Result& r, const HalfPlane& h, int W, int H) {
  std::vector<double> ones(r.out.size(), 1.0), grad_clip(r.clip.size(), 0.0);
  AntialiasParams<double> p;  // what the adjoint reads
  p.image = r.image.data();
  p.channels = 1;
  p.width = W;
  p.height = H;
  p.clip = r.clip.data();
  p.num_vertices = 3;
  antialias_backward(p, r.pairs, ones.data(), {nullptr, grad_clip.data()});
  double rate = 0;
  for (int k = 0; k < 3; ++k) rate += grad_clip[4 * k] * 2.0 * h.nx / W - grad_clip[4 * k + 1] * 2.0 * h.ny / H;
  return rate;
}
double image_sum(const Result& r) { return std::accumulate(r.out.begin(), r.out.end(), 0.0); }

}  // namespace

TEST_CASE("antialias topology: a quad's diagonal is shared and its outline is boundary", "[raster][antialias]") {
  const std::vector<std::int32_t> tris = {0, 1, 2, 0, 2, 3};
  const EdgeTopology t = build_edge_topology(tris.data(), 2, 4);
  REQUIRE(t.neighbour().size() == 6);
  // Edge 1 of triangle 0 (vertices 2, 0) is edge 2 of triangle 1 (vertices 0, 2).
  CHECK(t.neighbour()[1] == 3 * 1 + 2);
  CHECK(t.neighbour()[3 * 1 + 2] == 1);
  for (int e : {0, 2, 3, 4}) CHECK(t.neighbour()[e] == kBoundaryEdge);
}

TEST_CASE("antialias topology: duplicated vertices are welded by position, not by index", "[raster][antialias]") {
  // Triangle 1 uses copies (4, 5) of vertices 0 and 2.
  const std::vector<std::int32_t> tris = {0, 1, 2, 4, 5, 3};
  const std::vector<double> pos = {0, 0, 1, 0, 1, 1, 0, 1, 0, 0, 1, 1};
  const EdgeTopology by_index = build_edge_topology(tris.data(), 2, 6);
  for (std::int64_t e : by_index.neighbour()) CHECK(e == kBoundaryEdge);
  const EdgeTopology welded = build_edge_topology(tris.data(), 2, 6, pos.data(), 2);
  CHECK(welded.neighbour()[1] == 3 * 1 + 2);  // edge (2, 0) ~ edge (4, 5)
  CHECK(welded.neighbour()[3 * 1 + 2] == 1);
}

TEST_CASE("antialias topology: an edge of three triangles is non-manifold", "[raster][antialias]") {
  const std::vector<std::int32_t> tris = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  const EdgeTopology t = build_edge_topology(tris.data(), 3, 5);
  CHECK(t.neighbour()[2] == kNonManifoldEdge);  // edge (0, 1) of triangle 0
  CHECK(t.neighbour()[3 + 2] == kNonManifoldEdge);
  CHECK(t.neighbour()[6 + 2] == kNonManifoldEdge);
}

TEST_CASE("antialias topology: each one made has its own serial, copies keep it and a moved-from one is empty",
          "[raster][antialias]") {
  const std::vector<std::int32_t> tris = {0, 1, 2, 0, 2, 3};
  const EdgeTopology a = build_edge_topology(tris.data(), 2, 4), b = build_edge_topology(tris.data(), 2);
  const std::vector<double> pos = {0, 0, 1, 0, 1, 1, 0, 1};
  const EdgeTopology welded = build_edge_topology(tris.data(), 2, 4, pos.data(), 2);
  const EdgeTopology given(2, a.neighbour());
  CHECK(a.neighbour() == b.neighbour());
  for (const EdgeTopology* t : {&a, &b, &welded, &given}) CHECK(t->serial() != 0);
  CHECK(a.serial() != b.serial());
  CHECK(a.serial() != welded.serial());
  CHECK(given.serial() != a.serial());
  CHECK(EdgeTopology().serial() == 0);
  EdgeTopology copy = a;
  CHECK(copy.serial() == a.serial());
  CHECK(copy.neighbour() == a.neighbour());
  EdgeTopology moved = std::move(copy);
  CHECK(moved.serial() == a.serial());
  CHECK(moved.neighbour() == a.neighbour());
  CHECK(copy.serial() == 0);  // NOLINT(bugprone-use-after-move): left empty on purpose
  CHECK(copy.num_tris() == 0);
  CHECK(copy.neighbour().empty());
  copy = b;
  CHECK(copy.serial() == b.serial());
}

TEST_CASE("antialias topology: a hand-made table with a slot beyond its triangles or a wrong size is refused when made",
          "[raster][antialias]") {
  // An audit's finding: the table is public and was not checked, and the
  // antialias op checked only its size, so a slot of 10^6 for one triangle
  // made the silhouette prefilter and the walks read outside the triangles
  // (a segmentation fault).
  CHECK_THROWS_AS(EdgeTopology(1, {1000000, kBoundaryEdge, kBoundaryEdge}), IndexError);
  CHECK_THROWS_AS(EdgeTopology(1, {kBoundaryEdge, 3, kBoundaryEdge}), IndexError);
  CHECK_THROWS_AS(EdgeTopology(1, {kBoundaryEdge, kBoundaryEdge, -3}), IndexError);
  CHECK_THROWS_WITH(EdgeTopology(2, {0, 1, 2}), Catch::Contains("3 per triangle"));
  CHECK_THROWS_AS(EdgeTopology(-1, {}), ValueError);
  const EdgeTopology ok(2, {kBoundaryEdge, kNonManifoldEdge, 3, 2, kBoundaryEdge, kBoundaryEdge});
  CHECK(ok.num_tris() == 2);
}

TEST_CASE("antialias kernel: a vertical silhouette blends like a box filter of the covered fraction",
          "[raster][antialias]") {
  const int W = 8, H = 4;
  // A quad covering x < xs_edge over the full height; its diagonal crosses the image.
  for (double edge : {3.3, 2.7}) {
    const double xe = ndc_x(edge, W);
    const std::vector<double> xyz = {-2, -2, 0, xe, -2, 0, xe, 2, 0, -2, 2, 0};
    const Result r = render(xyz, {0, 1, 2, 0, 2, 3}, W, H);
    CHECK(r.stats.blended_pairs == H);
    CHECK(r.stats.candidate_pairs > H);  // the diagonal's pairs are candidates, but not blended
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double expected = x == 2 || x == 3 ? std::min(1.0, std::max(0.0, edge - x)) : r.image[y * W + x];
        INFO("edge " << edge << " pixel " << x << "," << y);
        CHECK(r.out[y * W + x] == Approx(expected).margin(1e-12));
      }
    for (const AntialiasPair& p : r.pairs) {
      CHECK(p.outside == p.inside + 1);
      CHECK(p.t == Approx(edge - 2.5).margin(1e-12));
    }
  }
}

TEST_CASE("antialias kernel: a quad filling the image is never blended", "[raster][antialias]") {
  const std::vector<double> xyz = {-1.5, -1.5, 0, 1.5, -1.5, 0, 1.5, 1.5, 0, -1.5, 1.5, 0};
  const Result r = render(xyz, {0, 1, 2, 0, 2, 3}, 16, 12);
  CHECK(r.stats.candidate_pairs > 0);
  CHECK(r.stats.blended_pairs == 0);
  CHECK(r.out == r.image);
}

TEST_CASE("antialias kernel: an edge whose neighbour folds back onto the same side is a silhouette",
          "[raster][antialias]") {
  const int W = 8, H = 4;
  const double xe = ndc_x(4.3, W);
  // Triangle 0 covers x < xe (full height). Triangle 1 shares its right edge;
  // its third vertex lies either beyond the edge (the surface continues) or
  // back on triangle 0's side, farther away (a fold: the edge is a silhouette).
  const std::vector<std::int32_t> tris = {0, 1, 2, 2, 1, 3};
  const std::vector<double> continues = {-3, -3, 0, xe, -3, 0, xe, 5, 0, 3, 1, 0};
  const std::vector<double> folds = {-3, -3, 0, xe, -3, 0, xe, 5, 0, -1, 1, 0.5};
  const Result a = render(continues, tris, W, H);
  CHECK(a.stats.blended_pairs == 0);
  CHECK(a.out == a.image);
  const Result b = render(folds, tris, W, H);
  CHECK(b.stats.blended_pairs == H);
  for (int y = 0; y < H; ++y) CHECK(b.out[y * W + 4] == Approx(0.3).margin(1e-12));
}

TEST_CASE("antialias kernel: the front triangle's silhouette blends over a triangle behind it",
          "[raster][antialias]") {
  const int W = 8, H = 4;
  const double xe = ndc_x(5.2, W);
  // Triangle 0 (front, z = -0.5) covers x < xe; triangle 1 (behind) covers everything.
  const std::vector<double> xyz = {-3, -3, -0.5, xe, -3, -0.5, xe, 5, -0.5, -9, -9, 0.5, 9, -9, 0.5, 0, 9, 0.5};
  const std::vector<std::int32_t> tris = {0, 1, 2, 3, 4, 5};
  Result r = render(xyz, tris, W, H);
  CHECK(r.stats.blended_pairs == H);
  for (const AntialiasPair& p : r.pairs) {
    CHECK(r.tri_id[p.inside] == 1);
    CHECK(r.tri_id[p.outside] == 2);
    CHECK(p.t == Approx(0.7).margin(1e-12));
  }
}

TEST_CASE("antialias kernel: a seam of duplicated vertices blends only when the topology does not weld it",
          "[raster][antialias]") {
  // The full-image quad again, its second triangle on copies (4, 5) of vertices 0 and 2.
  const std::vector<double> xyz = {-1.5, -1.5, 0, 1.5, -1.5, 0, 1.5, 1.5, 0, -1.5, 1.5, 0, -1.5, -1.5, 0, 1.5, 1.5, 0};
  const std::vector<std::int32_t> tris = {0, 1, 2, 4, 5, 3};
  const Result welded = render(xyz, tris, 16, 12);  // welds equal clip rows
  CHECK(welded.stats.blended_pairs == 0);
  CHECK(welded.out == welded.image);
  const EdgeTopology by_index = build_edge_topology(tris.data(), 2, 6);
  const Result seam = render(xyz, tris, 16, 12, &by_index);
  CHECK(seam.stats.blended_pairs > 0);
}

TEST_CASE("antialias kernel: the walk crosses interior edges to a silhouette owned by a sliver triangle",
          "[raster][antialias]") {
  const int W = 8, H = 4;
  const double x1 = ndc_x(3.6, W), xe = ndc_x(4.3, W);
  // Triangle 0 covers x < x1 (column 3's centre, 3.5); a strip x1 < x < xe of two
  // triangles covers no pixel centre but owns the silhouette at xe.
  const std::vector<double> xyz = {-3, -3, 0, x1, -3, 0, x1, 5, 0, xe, -3, 0, xe, 5, 0};
  const std::vector<std::int32_t> tris = {0, 1, 2, 1, 3, 4, 1, 4, 2};
  const Result r = render(xyz, tris, W, H);
  for (int y = 0; y < H; ++y) REQUIRE(r.tri_id[y * W + 4] == 0);
  CHECK(r.stats.blended_pairs == H);
  for (const AntialiasPair& p : r.pairs) {
    CHECK(p.a + p.b == 3 + 4);  // the strip's right edge
    CHECK(p.t == Approx(0.8).margin(1e-12));
  }
  for (int y = 0; y < H; ++y) CHECK(r.out[y * W + 4] == Approx(0.3).margin(1e-12));
}

TEST_CASE("antialias kernel: a straight silhouette at any angle moves the image sum at the covered-area rate",
          "[raster][antialias]") {
  // Each edge crossing is blended once (by the pixel pairs along the axis most
  // perpendicular to it), so d(sum)/d(shift) = edge length x colour step (1 here).
  const int W = 64, H = 64;
  const std::vector<std::int32_t> tri = {0, 1, 2};
  for (double degrees : {0.0, 5.7, 13.0, 30.0, 45.0, 60.0, 89.0, 120.0, 167.0}) {
    const HalfPlane h = half_plane(degrees, 0.0, W, H);
    const Result r = render(h.xyz, tri, W, H);
    const double exact = length_in_image(h, W, H);
    const double adjoint = adjoint_shift_rate(r, h, W, H);
    const double step = 1e-3;
    const double fd = (image_sum(render(half_plane(degrees, step, W, H).xyz, tri, W, H)) -
                       image_sum(render(half_plane(degrees, -step, W, H).xyz, tri, W, H))) /
                      (2 * step);
    INFO("angle " << degrees << " deg: exact " << exact << ", adjoint " << adjoint << ", forward FD " << fd
                  << ", blended pairs " << r.stats.blended_pairs);
    CHECK(adjoint == Approx(exact).epsilon(0.02));
    CHECK(fd == Approx(adjoint).epsilon(1e-6));
  }
}

TEST_CASE("antialias kernel: a slanted half-plane approximates the exact area coverage of every pixel",
          "[raster][antialias]") {
  const int W = 64, H = 64;
  for (double degrees : {0.0, 5.7, 13.0, 30.0, 45.0, 60.0, 89.0, 120.0}) {
    const HalfPlane h = half_plane(degrees, 0.0, W, H);
    const Result r = render(h.xyz, {0, 1, 2}, W, H);
    double err_aa = 0, err_plain = 0, worst_aa = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double exact = covered_area(h, x, y);
        err_aa += std::abs(r.out[y * W + x] - exact);
        err_plain += std::abs(r.image[y * W + x] - exact);
        worst_aa = std::max(worst_aa, std::abs(r.out[y * W + x] - exact));
      }
    err_aa /= W * H;
    err_plain /= W * H;
    INFO("angle " << degrees << " deg: mean abs error " << err_aa << " antialiased, " << err_plain
                  << " without, worst antialiased pixel " << worst_aa);
    // The box filter along one axis reads the edge at the row (column) centre:
    // exact for axis-aligned edges, and a pixel misses at most a corner triangle of
    // |slope| / 8 of its area, so the error grows towards 45 deg (0.76x the
    // unblended error there, 0.1x at 30 deg, < 0.02x at 13 deg).
    CHECK(err_aa < (degrees == 45.0 ? 0.8 : 0.5) * err_plain);
    CHECK(worst_aa < 0.13);
  }
}
