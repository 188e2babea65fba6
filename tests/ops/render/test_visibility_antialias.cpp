// The visibility antialias op: finite-difference checks on interpenetrating,
// occluding and random triangle pairs, hard cases (an intersection line
// through pixel centres, grazing intersections, coplanar overlaps),
// agreement with antialias where no intersection exists, intersection
// gradients antialias does not give, thread-count determinism, float32, and
// argument checks.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "ops/ops.h"
#include "ops/render/visibility_antialias.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

struct Screen {
  double x, y, z;  // screen x, y and z_ndc
};
Screen screen_of(const Tensor& clip, std::int64_t i, int W, int H) {
  const double w = clip.at({i, 3});
  return {0.5 * W * (1 + clip.at({i, 0}) / w), 0.5 * H * (1 - clip.at({i, 1}) / w), clip.at({i, 2}) / w};
}

// Smallest distance (pixels) of any pixel centre or mid-point between
// neighbouring centres to a triangle edge, or to the line where the depth
// planes of two triangles cross (a, b: screen slopes of z_ndc). A gradient
// check with steps moving the geometry by less than this is on one smooth
// piece of the op.
double boundary_margin(const Tensor& clip, const Tensor& tris, int W, int H) {
  const std::int64_t m = tris.size(0);
  struct Plane {
    double a, b, c;  // z = a x + b y + c
  };
  std::vector<Plane> planes;
  double best = 1e300;
  auto visit = [&](auto&& dist) {
    for (int y2 = 0; y2 <= 2 * H; ++y2)
      for (int x2 = 0; x2 <= 2 * W; ++x2) {
        if ((x2 % 2 == 0) && (y2 % 2 == 0)) continue;
        best = std::min(best, dist(0.5 * x2, 0.5 * y2));
      }
  };
  for (std::int64_t t = 0; t < m; ++t) {
    Screen s[3];
    for (int k = 0; k < 3; ++k) s[k] = screen_of(clip, static_cast<std::int64_t>(tris.at({t, k})), W, H);
    for (int k = 0; k < 3; ++k) {
      const Screen &p = s[k], &q = s[(k + 1) % 3];
      const double dx = q.x - p.x, dy = q.y - p.y, len2 = dx * dx + dy * dy;
      visit([&](double px, double py) {
        const double u = std::clamp(((px - p.x) * dx + (py - p.y) * dy) / len2, 0.0, 1.0);
        return std::hypot(px - p.x - u * dx, py - p.y - u * dy);
      });
    }
    // z = a x + b y + c through the three vertices (Cramer's rule).
    const double det = (s[1].x - s[0].x) * (s[2].y - s[0].y) - (s[2].x - s[0].x) * (s[1].y - s[0].y);
    const double a = ((s[1].z - s[0].z) * (s[2].y - s[0].y) - (s[2].z - s[0].z) * (s[1].y - s[0].y)) / det;
    const double b = ((s[1].x - s[0].x) * (s[2].z - s[0].z) - (s[2].x - s[0].x) * (s[1].z - s[0].z)) / det;
    planes.push_back({a, b, s[0].z - a * s[0].x - b * s[0].y});
  }
  for (std::size_t i = 0; i < planes.size(); ++i)
    for (std::size_t j = i + 1; j < planes.size(); ++j) {
      const double da = planes[i].a - planes[j].a, db = planes[i].b - planes[j].b, dc = planes[i].c - planes[j].c;
      const double norm = std::hypot(da, db);
      if (norm < 1e-12) continue;
      visit([&](double px, double py) { return std::abs(da * px + db * py + dc) / norm; });
    }
  return best;
}

// Gradient checks below use clip steps of at most 2 eps = 2e-5, which move
// edges by < 1e-3 px and, at the depth slopes used, intersection lines by
// < 1e-3 px (the grazing case uses a smaller step): scenes keep a margin of
// kMargin px (boundary_margin) so that they stay on one smooth piece.
constexpr double kMargin = 4e-3;

// `clip` itself if its margin is at least kMargin, else the first of a fixed
// sequence of small jitters of it in x and y (+-0.01 in clip units; depths
// stay) that has one; an undefined tensor if none does.
Tensor try_margin(const Tensor& clip, const Tensor& tris, int W, int H) {
  if (boundary_margin(clip, tris, W, H) >= kMargin) return clip;
  for (std::uint64_t seed = 1; seed < 100; ++seed) {
    std::vector<double> c = clip.to_vector();
    const std::vector<double> j = Tensor::uniform(clip.shape(), -0.01, 0.01, seed, DType::Float64).to_vector();
    for (std::size_t i = 0; i < c.size(); ++i)
      if (i % 4 < 2) c[i] += j[i];
    Tensor moved = Tensor::from_values(c, clip.shape(), DType::Float64);
    if (boundary_margin(moved, tris, W, H) >= kMargin) return moved;
  }
  return Tensor();
}
Tensor with_margin(const Tensor& clip, const Tensor& tris, int W, int H) {
  Tensor moved = try_margin(clip, tris, W, H);
  if (!moved.defined()) FAIL("no jitter of the scene keeps pixel centres and mid-points off its boundaries");
  return moved;
}

// Two triangles cutting through each other: A at constant depth, B tilted in
// depth so that their intersection line crosses the image (mostly along x
// when `along_x`, mostly along y otherwise); w varies per vertex.
Tensor crossing_clip(bool along_x) {
  if (along_x)
    return Tensor::from_values({-0.9, -0.8, 0.0, 1.0,   //
                                0.85, -0.7, 0.0, 1.2,   //
                                0.1, 0.9, 0.0, 0.9,     //
                                -0.8, 0.85, -0.5, 1.1,  //
                                0.83, 0.6, -0.35, 1.0,  //
                                0.05, -0.9, 0.62, 1.15},
                               {6, 4}, DType::Float64);
  return Tensor::from_values({-0.9, -0.8, 0.0, 1.0,   //
                              0.85, -0.7, 0.0, 1.2,   //
                              0.1, 0.9, 0.0, 0.9,     //
                              -0.85, 0.8, -0.55, 1.1, //
                              -0.7, -0.85, -0.4, 1.0, //
                              0.9, 0.05, 0.6, 1.15},
                             {6, 4}, DType::Float64);
}
Tensor pair_triangles() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3}); }

raster::VisibilityAntialiasStats stats_of(const Tensor& image, const Tensor& clip, const Tensor& tris, int W, int H) {
  NoGradGuard ng;
  raster::VisibilityAntialiasStats stats;
  VisibilityAntialiasOptions opt;
  opt.stats = &stats;
  visibility_antialias(image, rasterize(clip, tris, {W, H}), clip, tris, opt);
  return stats;
}

// rasterize -> interpolate -> visibility_antialias, as a gradcheck function of (clip, colours).
Tensor render(const Tensor& clip, const Tensor& colours, const Tensor& tris, int W, int H) {
  GBuffer gb = rasterize(clip, tris, {W, H});
  return visibility_antialias(interpolate(colours, gb, tris), gb, clip, tris);
}

}  // namespace

TEST_CASE("visibility_antialias: gradients at an intersection line along x match finite differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 24, H = 20;
  Tensor tris = pair_triangles();
  Tensor clip = with_margin(crossing_clip(true), tris, W, H).set_requires_grad();
  Tensor image = gr::testing::random_input({H, W, 3}, 0.0, 1.0, 5);
  const auto stats = stats_of(image, clip, tris, W, H);
  CHECK(stats.intersection_pairs >= 5);
  CHECK(stats.edge_pairs >= 20);
  auto f = [&](const Inputs& in) { return visibility_antialias(in[0], rasterize(in[1], tris, {W, H}), in[1], tris); };
  require_gradcheck("visibility_antialias along x (image, clip)", f, {image, clip}, GradcheckOptions{1e-5});
}

TEST_CASE("visibility_antialias: gradients at an intersection line along y, through interpolated colours, match "
          "finite differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 24, H = 20;
  Tensor tris = pair_triangles();
  Tensor clip = with_margin(crossing_clip(false), tris, W, H).set_requires_grad();
  Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 8);
  CHECK(stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H).intersection_pairs >= 5);
  require_gradcheck("visibility_antialias along y (clip, colours)",
                    [&](const Inputs& in) { return render(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{1e-5});
}

TEST_CASE("visibility_antialias: gradients on random interpenetrating triangle pairs match finite differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 16, H = 14;
  Tensor tris = pair_triangles();
  int checked = 0;
  for (std::uint64_t seed = 1; checked < 4 && seed < 400; ++seed) {
    // Random vertices in the image, depths in [-0.6, 0.6], w in [0.8, 1.3].
    Tensor u = Tensor::uniform({6, 4}, 0, 1, seed, DType::Float64);
    std::vector<double> c = u.to_vector();
    for (int i = 0; i < 6; ++i) {
      double* r = &c[4 * i];
      const double w = 0.8 + 0.5 * r[3];
      r[0] = (1.8 * r[0] - 0.9) * w, r[1] = (1.8 * r[1] - 0.9) * w, r[2] = (1.2 * r[2] - 0.6) * w, r[3] = w;
    }
    Tensor clip = try_margin(Tensor::from_values(c, {6, 4}, DType::Float64), tris, W, H);
    if (!clip.defined()) continue;
    clip.set_requires_grad();
    if (stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H).intersection_pairs < 3) continue;
    Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 100 + seed);
    INFO("seed " << seed);
    require_gradcheck("visibility_antialias random pair (clip, colours)",
                      [&](const Inputs& in) { return render(in[0], in[1], tris, W, H); }, {clip, colours},
                      GradcheckOptions{1e-5});
    ++checked;
  }
  CHECK(checked == 4);
}

TEST_CASE("visibility_antialias: gradients at a grazing intersection (nearly parallel faces) match finite differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 24, H = 20;
  // B's depth differs from A's constant 0 by a small slope: about 4e-4 in z_ndc per pixel.
  Tensor clip = Tensor::from_values({-0.9, -0.8, 0.0, 1.0, 0.85, -0.7, 0.0, 1.0, 0.1, 0.9, 0.0, 1.0,  //
                                     -0.8, 0.85, -0.0042, 1.0, 0.83, 0.6, -0.0031, 1.0, 0.05, -0.9, 0.0043, 1.0},
                                    {6, 4}, DType::Float64);
  Tensor tris = pair_triangles();
  clip = with_margin(clip, tris, W, H).set_requires_grad();
  Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 12);
  // The crossing moves by (depth change) / (depth slope): steps of 2e-7 move it < 1e-3 px.
  CHECK(stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H).intersection_pairs >= 5);
  GradcheckOptions opt{1e-7};
  opt.rtol = 1e-4;
  const auto r = require_gradcheck("visibility_antialias grazing (clip, colours)",
                                   [&](const Inputs& in) { return render(in[0], in[1], tris, W, H); },
                                   {clip, colours}, opt);
  CHECK(std::isfinite(r.worst_analytic));
}

// A surface folded along a horizontal crease at y_ndc = -0.05 (A0 below, A1
// above, meeting at depth -0.02; slopes dz/dy_ndc 0.05 and 0.2) through a flat
// one at z = 0 (B, covering the image): A1 crosses B at y_ndc = 0.05, between
// the centres of rows 4 (y_ndc -0.125, A0 in front) and 3 (0.125, B in
// front), above the crease; A0's plane, extended, would cross only at 0.35.
Tensor folded_clip() {
  const double c = -0.05, e = -0.02, s0 = 0.05, s1 = 0.2;
  return Tensor::from_values({-3, c, e, 1, 3, c, e, 1, 0, -4, e + s0 * (-4 - c), 1, 0, 4, e + s1 * (4 - c), 1,  //
                              -4, -4, 0, 1, 4, -4, 0, 1, 0, 4, 0, 1},
                             {7, 4}, DType::Float64);
}
Tensor folded_triangles() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 1, 0, 3, 4, 5, 6}, {3, 3}); }

TEST_CASE("visibility_antialias: an intersection is located on the triangles where it happens, not on the planes "
          "of those visible at the centres",
          "[ops][visibility_antialias]") {
  const int W = 8, H = 8;
  Tensor clip = folded_clip(), tris = folded_triangles();
  // Flat colours: A red, B blue.
  Tensor colours = Tensor::from_values({1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 1}, {7, 3},
                                       DType::Float64);
  NoGradGuard ng;
  GBuffer gb = rasterize(clip, tris, {W, H});
  REQUIRE(gb.tri_id.at({3, 3}) == 3);  // B at row 3
  REQUIRE(gb.tri_id.at({4, 3}) == 1);  // A0 at row 4
  const Tensor out = render(clip, colours, tris, W, H);
  // The crossing is at t = (0.05 + 0.125) / 0.25 = 0.7 from row 4's centre, so
  // row 3 takes 0.7 - 0.5 = 0.2 of row 4's colour; row 4 stays red.
  CHECK(out.at({3, 3, 0}) == Approx(0.2).margin(1e-12));
  CHECK(out.at({3, 3, 2}) == Approx(0.8).margin(1e-12));
  CHECK(out.at({4, 3, 0}) == Approx(1.0).margin(1e-12));
}

TEST_CASE("visibility_antialias: gradients at an intersection beyond a crease match finite differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 8, H = 8;
  Tensor tris = folded_triangles();
  Tensor clip = with_margin(folded_clip(), tris, W, H).set_requires_grad();
  Tensor colours = gr::testing::random_input({7, 3}, 0.1, 0.9, 51);
  CHECK(stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H).intersection_pairs >= 5);
  require_gradcheck("visibility_antialias crease (clip, colours)",
                    [&](const Inputs& in) { return render(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{1e-5});
}

TEST_CASE("visibility_antialias: an occluder nearer than the surface behind gets its silhouette found from either side",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 24, H = 20;
  // A large triangle far away and a small one in front, overlapping but not intersecting.
  Tensor clip = Tensor::from_values({-0.9, -0.8, 0.5, 1.0, 0.85, -0.7, 0.4, 1.2, 0.1, 0.9, 0.45, 0.9,  //
                                     -0.35, -0.3, -0.2, 1.1, 0.45, -0.1, -0.3, 1.0, -0.05, 0.55, -0.25, 1.05},
                                    {6, 4}, DType::Float64);
  Tensor tris = pair_triangles();
  clip = with_margin(clip, tris, W, H).set_requires_grad();
  Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 21);
  const auto stats = stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H);
  CHECK(stats.intersection_pairs == 0);
  CHECK(stats.edge_pairs >= 30);
  require_gradcheck("visibility_antialias occlusion (clip, colours)",
                    [&](const Inputs& in) { return render(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{1e-5});
}

TEST_CASE("visibility_antialias: on one closed convex mesh it equals antialias (image and gradients)",
          "[ops][visibility_antialias]") {
  raster::Mesh mesh = raster::make_icosphere(2, 0.8f);
  const int W = 48, H = 40;
  Tensor mvp = matmul(perspective(Tensor::scalar(0.9, DType::Float64), double(W) / H, 0.5, 10.0),
                      look_at(Tensor::from_values({0.3, 0.4, 2.6}, {3}, DType::Float64),
                              Tensor::zeros({3}, DType::Float64), Tensor::from_values({0, 1, 0}, {3}, DType::Float64)));
  Tensor pos = cast(mesh.positions, DType::Float64).set_requires_grad();
  Tensor colours = Tensor::uniform({mesh.num_vertices(), 3}, 0.1, 0.9, 4, DType::Float64);
  AntialiasTopology topo = antialias_topology(mesh.triangles, mesh.positions);
  auto run = [&](bool visibility) {
    Tensor clip = transform_points(pos, mvp);
    GBuffer gb = rasterize(clip, mesh.triangles, {W, H});
    Tensor img = interpolate(colours, gb, mesh.triangles);
    Tensor out;
    if (visibility) {
      VisibilityAntialiasOptions o;
      o.topology = topo;
      out = visibility_antialias(img, gb, clip, mesh.triangles, o);
    } else {
      AntialiasOptions o;
      o.topology = topo;
      out = antialias(img, gb, clip, mesh.triangles, o);
    }
    backward(sum(out * out));
    std::vector<double> r = out.to_vector();
    for (double x : pos.grad().to_vector()) r.push_back(x);
    pos.zero_grad();
    return r;
  };
  const auto a = run(false), v = run(true);
  REQUIRE(a.size() == v.size());
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - v[i]));
  CHECK(worst == 0.0);
}

TEST_CASE("visibility_antialias: an intersection gets depth gradients where antialias gives none",
          "[ops][visibility_antialias]") {
  const int W = 24, H = 20;
  Tensor tris = pair_triangles();
  Tensor colours = Tensor::from_values({0.9, 0.2, 0.1, 0.9, 0.2, 0.1, 0.9, 0.2, 0.1,  //
                                        0.1, 0.3, 0.9, 0.1, 0.3, 0.9, 0.1, 0.3, 0.9},
                                       {6, 3}, DType::Float64);
  auto depth_grad = [&](bool visibility) {
    Tensor clip = crossing_clip(true).set_requires_grad();
    GBuffer gb = rasterize(clip, tris, {W, H});
    Tensor img = interpolate(colours, gb, tris);
    Tensor out = visibility ? visibility_antialias(img, gb, clip, tris) : antialias(img, gb, clip, tris);
    backward(sum(out));  // the image sum: its change is (c_A - c_B) times the area swept by the line
    // Pushing triangle B away (+z on all its vertices) moves the line so that A covers more.
    const std::vector<double> g = clip.grad().to_vector();
    return g[4 * 3 + 2] + g[4 * 4 + 2] + g[4 * 5 + 2];
  };
  CHECK(depth_grad(false) == 0.0);
  const double gv = depth_grad(true);
  // A's colour sum is 1.2, B's 1.3: more of A lowers the image sum.
  CHECK(gv < 0.0);
}

// Two triangles covering the whole image: A at z = 0, B's depth
// z = s (y_ndc - y0) crossing zero on the row of pixel centres at screen
// y 5.5 (row 5), shifted by `shift` px; the line is the only boundary.
Tensor centre_row_clip(double shift, int H) {
  const double y = 1.0 - 2.0 * 5.5 / H + 2.0 * shift / H, s = 0.2;  // |z| < 1 at every vertex
  return Tensor::from_values({-4, -3, 0, 1, 4, -3, 0, 1, 0.0, 4, 0, 1,  //
                              -4, 3.2, s * (3.2 - y), 1, 4, 3, s * (3 - y), 1, 0.1, -4, s * (-4 - y), 1},
                             {6, 4}, DType::Float64);
}

// Flat colours (one per triangle): the one-sided blend takes each neighbour's
// colour at its own centre, so with varying colours the image jumps by part of
// a pixel's colour change when a boundary crosses a centre (as antialias's does).
Tensor flat_pair_colours() {
  return Tensor::from_values({0.9, 0.2, 0.1, 0.9, 0.2, 0.1, 0.9, 0.2, 0.1,  //
                              0.1, 0.3, 0.9, 0.1, 0.3, 0.9, 0.1, 0.3, 0.9},
                             {6, 3}, DType::Float64);
}

TEST_CASE("visibility_antialias: an intersection line through pixel centres keeps a flat-coloured image continuous "
          "and finite",
          "[ops][visibility_antialias]") {
  const int W = 16, H = 16;
  Tensor tris = pair_triangles();
  std::vector<std::vector<double>> images;
  for (double shift : {-1e-9, 0.0, 1e-9}) {
    Tensor clip = centre_row_clip(shift, H).set_requires_grad();
    Tensor out = render(clip, flat_pair_colours(), tris, W, H);
    backward(sum(out * out));
    CHECK(all_finite(out));
    CHECK(all_finite(clip.grad()));
    images.push_back(out.to_vector());
  }
  double jump = 0;
  for (std::size_t i = 0; i < images[0].size(); ++i)
    jump = std::max({jump, std::abs(images[0][i] - images[1][i]), std::abs(images[2][i] - images[1][i])});
  CHECK(jump < 1e-6);
}

TEST_CASE("visibility_antialias: gradients at an intersection line through a row of pixel centres match finite "
          "differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 16, H = 16;
  Tensor tris = pair_triangles();
  Tensor clip = centre_row_clip(0.0, H).set_requires_grad();
  Tensor colours = flat_pair_colours().set_requires_grad();
  CHECK(stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H).intersection_pairs >= 10);
  require_gradcheck("visibility_antialias through pixel centres (clip, colours)",
                    [&](const Inputs& in) { return render(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{1e-6});
}

TEST_CASE("visibility_antialias: coplanar overlapping faces blend no crossing and give finite gradients",
          "[ops][visibility_antialias]") {
  const int W = 24, H = 20;
  // Two triangles in the same plane z = 0.1 x + 0.2 y (w = 1), overlapping.
  auto z = [](double x, double y) { return 0.1 * x + 0.2 * y; };
  std::vector<double> c = {-0.9, -0.8, 0, 1, 0.85, -0.7, 0, 1, 0.1, 0.9, 0, 1,
                           -0.6, 0.7, 0, 1, 0.8, 0.5, 0, 1, -0.2, -0.85, 0, 1};
  for (int i = 0; i < 6; ++i) c[4 * i + 2] = z(c[4 * i], c[4 * i + 1]);
  Tensor clip = Tensor::from_values(c, {6, 4}, DType::Float64).set_requires_grad();
  Tensor tris = pair_triangles();
  Tensor colours = Tensor::uniform({6, 3}, 0.1, 0.9, 41, DType::Float64);
  CHECK(stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip, tris, W, H).intersection_pairs == 0);
  Tensor out = render(clip, colours, tris, W, H);
  backward(sum(out * out));
  CHECK(all_finite(out));
  CHECK(all_finite(clip.grad()));
}

TEST_CASE("visibility_antialias: gradients on coplanar overlapping faces, moved within their plane, match finite "
          "differences",
          "[ops][visibility_antialias][gradcheck]") {
  const int W = 24, H = 20;
  // The faces of the test above in the plane z = 0 (w = 1), as a function of
  // the screen positions (x, y) of the six vertices, so every perturbation
  // keeps them coplanar and every depth is exactly 0: the index decides, and
  // the smaller index's edges over the other face are blended as occlusions.
  // (In a tilted common plane the rasterizer's depths differ by rounding, so
  // which face shows at a centre flips between perturbations, as z-fighting
  // does in any depth buffer; a perturbation that tilts one face makes the
  // other show through on a whole side of a line. No derivative exists there.)
  Tensor xy = Tensor::from_values({-0.9, -0.8, 0.85, -0.7, 0.1, 0.9, -0.6, 0.7, 0.8, 0.5, -0.2, -0.85}, {6, 2},
                                  DType::Float64)
                  .set_requires_grad();
  const Tensor to_clip = Tensor::from_values({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1}, {3, 4}, DType::Float64);
  const auto clip_of = [&](const Tensor& p) {
    return matmul(concat({p, Tensor::ones({6, 1}, DType::Float64)}, 1), to_clip);
  };
  Tensor tris = pair_triangles();
  Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 43);
  {
    NoGradGuard ng;
    const auto stats = stats_of(Tensor::zeros({H, W, 3}, DType::Float64), clip_of(xy), tris, W, H);
    CHECK(stats.intersection_pairs == 0);
    CHECK(stats.edge_pairs >= 20);
  }
  require_gradcheck("visibility_antialias coplanar (xy, colours)",
                    [&](const Inputs& in) { return render(clip_of(in[0]), in[1], tris, W, H); }, {xy, colours},
                    GradcheckOptions{1e-6});
}

TEST_CASE("visibility_antialias: image and gradients are bit-identical for 1, 2 and 8 threads",
          "[ops][visibility_antialias][determinism]") {
  // Two interpenetrating icospheres: silhouettes, occlusion and an intersection curve.
  raster::Mesh a = raster::make_icosphere(3, 0.8f), b = raster::make_icosphere(2, 0.6f);
  const std::int64_t na = a.num_vertices(), nb = b.num_vertices();
  std::vector<double> pos;
  for (double x : a.positions.to_vector()) pos.push_back(x);
  const std::vector<double> pb = b.positions.to_vector();
  for (std::int64_t i = 0; i < nb; ++i)
    for (int k = 0; k < 3; ++k) pos.push_back(pb[3 * i + k] + (k == 0 ? 0.55 : k == 1 ? 0.2 : 0.3));
  std::vector<std::int32_t> tri;
  for (double x : a.triangles.to_vector()) tri.push_back(static_cast<std::int32_t>(x));
  for (double x : b.triangles.to_vector()) tri.push_back(static_cast<std::int32_t>(x) + static_cast<std::int32_t>(na));
  Tensor tris = Tensor::from_vector(tri, {static_cast<std::int64_t>(tri.size() / 3), 3});
  const int W = 96, H = 80;
  Tensor mvp = matmul(perspective(Tensor::scalar(0.9, DType::Float64), double(W) / H, 0.5, 10.0),
                      look_at(Tensor::from_values({0.3, 0.5, 2.8}, {3}, DType::Float64),
                              Tensor::zeros({3}, DType::Float64), Tensor::from_values({0, 1, 0}, {3}, DType::Float64)));
  Tensor colours = Tensor::uniform({na + nb, 3}, 0.1, 0.9, 9, DType::Float64);
  AntialiasTopology topo = antialias_topology(tris, Tensor::from_values(pos, {na + nb, 3}, DType::Float64));
  auto run = [&](int threads, DType dtype, raster::VisibilityAntialiasStats* stats) {
    set_num_threads(threads);
    Tensor p = cast(Tensor::from_values(pos, {na + nb, 3}, DType::Float64), dtype).detach().set_requires_grad();
    Tensor col = cast(colours, dtype).detach().set_requires_grad();
    Tensor clip = transform_points(p, cast(mvp, dtype));
    GBuffer gb = rasterize(clip, tris, {W, H});
    VisibilityAntialiasOptions o;
    o.topology = topo;
    o.stats = stats;
    Tensor img = visibility_antialias(interpolate(col, gb, tris), gb, clip, tris, o);
    backward(sum(img * img));
    std::vector<double> r = img.to_vector();
    const std::size_t n_image = r.size();
    for (const Tensor& t : {p.grad(), col.grad()})
      for (double x : t.to_vector()) r.push_back(x);
    (void)n_image;
    return r;
  };
  raster::VisibilityAntialiasStats stats;
  for (DType dtype : {DType::Float64, DType::Float32}) {
    const auto one = run(1, dtype, &stats);
    CHECK(stats.intersection_pairs > 20);
    CHECK(all_finite(Tensor::from_values(one, {static_cast<std::int64_t>(one.size())}, DType::Float64)));
    for (int threads : {2, 8}) {
      const auto other = run(threads, dtype, nullptr);
      std::size_t first = 0;
      while (first < one.size() && one[first] == other[first]) ++first;
      INFO(threads << " threads: first difference at element " << first << " of " << one.size());
      CHECK(first == one.size());
    }
  }
  set_num_threads(0);
}

TEST_CASE("visibility_antialias: float32 agrees with float64", "[ops][visibility_antialias]") {
  const int W = 24, H = 20;
  Tensor clip = crossing_clip(true), tris = pair_triangles();
  Tensor colours = Tensor::uniform({6, 3}, 0.1, 0.9, 3, DType::Float64);
  NoGradGuard ng;
  const std::vector<double> a = render(clip, colours, tris, W, H).to_vector();
  const Tensor b = render(cast(clip, DType::Float32), cast(colours, DType::Float32), tris, W, H);
  CHECK(b.dtype() == DType::Float32);
  const std::vector<double> vb = b.to_vector();
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - vb[i]));
  CHECK(worst < 1e-4);
}

TEST_CASE("visibility_antialias: bad arguments throw with messages naming the argument",
          "[ops][visibility_antialias]") {
  Tensor clip = crossing_clip(true);
  Tensor tris = pair_triangles();
  GBuffer gb = rasterize(clip, tris, {24, 20});
  Tensor image = Tensor::zeros({20, 24, 3}, DType::Float64);
  auto throws = [&](auto&& call, const std::string& needle) {
    try {
      call();
      FAIL("no exception; expected one mentioning " << needle);
    } catch (const Error& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find("visibility_antialias") != std::string::npos);
      CHECK(std::string(e.what()).find(needle) != std::string::npos);
    }
  };
  throws([&] { visibility_antialias(Tensor::zeros({20, 24}, DType::Float64), gb, clip, tris); }, "'image'");
  throws([&] { visibility_antialias(Tensor::zeros({20, 24, 3}, DType::Float32), gb, clip, tris); }, "'image'");
  throws([&] { visibility_antialias(Tensor::zeros({20, 25, 3}, DType::Float64), gb, clip, tris); }, "'gbuffer'");
  throws([&] { visibility_antialias(image, GBuffer{}, clip, tris); }, "'gbuffer'");
  throws([&] { visibility_antialias(image, gb, Tensor::zeros({6, 3}, DType::Float64), tris); }, "'clip'");
  throws([&] { visibility_antialias(image, gb, clip, cast(tris, DType::Float32)); }, "'triangles'");
  throws([&] { visibility_antialias(image, gb, clip, Tensor::from_vector<std::int32_t>({0, 1, 9}, {1, 3})); },
         "tris[0][2]");
  Tensor nan_clip = clip.copy();
  nan_clip.data<double>()[5] = std::nan("");
  throws([&] { visibility_antialias(image, gb, nan_clip, tris); }, "clip[5]");
  VisibilityAntialiasOptions opt;
  opt.topology = antialias_topology(Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3}));
  throws([&] { visibility_antialias(image, gb, clip, tris, opt); }, "'topology'");
  GBuffer bad_ids = gb;
  bad_ids.tri_id = gb.tri_id.copy();
  bad_ids.tri_id.data<std::int32_t>()[3] = 7;
  throws([&] { visibility_antialias(image, bad_ids, clip, tris); }, "tri_id[3]");
}

TEST_CASE("visibility_antialias: a batch (antialias_batch with visibility) equals one call per image bit for bit",
          "[ops][visibility_antialias][batch]") {
  const int W = 24, H = 20;
  const Tensor tris = pair_triangles();
  // Image 0: the intersection along x; image 1: along y.
  const Tensor clips = concat({reshape(crossing_clip(true), {1, 6, 4}), reshape(crossing_clip(false), {1, 6, 4})}, 0);
  const Tensor colours = testing::random_input({2, 6, 3}, 0, 1, 11);
  const Tensor weights = testing::random_input({2, H, W, 3}, -1, 1, 12);
  auto run = [&](bool batched) {
    Tensor clip = clips.detach().set_requires_grad(), col = colours.detach().set_requires_grad();
    std::vector<Tensor> images;
    if (batched) {
      AntialiasOptions o;
      o.visibility = true;
      const GBuffer gb = rasterize_batch(clip, tris, {W, H});
      images.push_back(antialias_batch(interpolate_batch(col, gb, tris), gb, clip, tris, o));
    } else {
      for (int b = 0; b < 2; ++b) {
        const Tensor c = reshape(slice(clip, 0, b, b + 1), {6, 4}), a = reshape(slice(col, 0, b, b + 1), {6, 3});
        const GBuffer gb = rasterize(c, tris, {W, H});
        images.push_back(reshape(visibility_antialias(interpolate(a, gb, tris), gb, c, tris), {1, H, W, 3}));
      }
    }
    const Tensor img = concat(images, 0);
    backward(sum(mul(img, weights)));
    std::vector<double> out = img.to_vector();
    for (const Tensor& g : {clip.grad(), col.grad()})
      for (double x : g.to_vector()) out.push_back(x);
    return out;
  };
  const std::vector<double> separate = run(false);
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    CHECK(run(true) == separate);
  }
  set_num_threads(0);
}

TEST_CASE("visibility_antialias: pos_gradient_boost scales only the clip gradient",
          "[ops][visibility_antialias]") {
  const int W = 24, H = 20;
  const Tensor tris = pair_triangles();
  const Tensor weights = testing::random_input({H, W, 3}, -1, 1, 13);
  auto grads = [&](double boost) {
    Tensor clip = crossing_clip(true).set_requires_grad();
    const GBuffer gb = rasterize(clip.detach(), tris, {W, H});
    Tensor image = testing::random_input({H, W, 3}, 0, 1, 14).set_requires_grad();
    VisibilityAntialiasOptions o;
    o.pos_gradient_boost = boost;
    backward(sum(mul(visibility_antialias(image, gb, clip, tris, o), weights)));
    return std::make_pair(clip.grad().to_vector(), image.grad().to_vector());
  };
  const auto [clip1, image1] = grads(1.0);
  const auto [clip3, image3] = grads(3.0);
  REQUIRE(std::any_of(clip1.begin(), clip1.end(), [](double g) { return g != 0.0; }));
  for (std::size_t i = 0; i < clip1.size(); ++i) CHECK(clip3[i] == Approx(3.0 * clip1[i]).epsilon(1e-15).margin(0));
  CHECK(image3 == image1);
}
