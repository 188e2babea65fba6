// The antialias op: finite-difference checks (alone and in the full chain from
// model space), silhouette gradients where interior gradients vanish, no
// blending across a closed mesh's interior edges, thread-count determinism and
// argument checks.
#include <catch2/catch.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <vector>

#include "autodiff/base/memory.h"
#include "ops/render/antialias.h"
#include "ops/ops.h"
#include "ops/clip_scenes.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;
using gr::testing::two_triangles;
using gr::testing::two_triangles_clip;

namespace {

// Smallest distance (in pixels) of any pixel centre, and any mid-point between
// neighbouring centres, to any triangle edge of `clip` (w > 0) in a
// W x H image. A gradient check with steps of up to d pixels needs d below it.
double edge_margin(const Tensor& clip, const Tensor& tris, int W, int H) {
  const std::int64_t m = tris.size(0);
  double best = 1e300;
  for (std::int64_t t = 0; t < m; ++t)
    for (int k = 0; k < 3; ++k) {
      double s[2][2];
      for (int e = 0; e < 2; ++e) {
        const std::int64_t i = static_cast<std::int64_t>(tris.at({t, (k + e) % 3}));
        const double w = clip.at({i, 3});
        s[e][0] = 0.5 * W * (1 + clip.at({i, 0}) / w);
        s[e][1] = 0.5 * H * (1 - clip.at({i, 1}) / w);
      }
      const double dx = s[1][0] - s[0][0], dy = s[1][1] - s[0][1], len = std::hypot(dx, dy);
      for (int y2 = 0; y2 <= 2 * H; ++y2)
        for (int x2 = 0; x2 <= 2 * W; ++x2) {
          if ((x2 % 2 == 0) && (y2 % 2 == 0)) continue;  // pixel corners do not matter
          const double px = 0.5 * x2, py = 0.5 * y2;      // centres at odd halves, mid-points at integers
          // Distance to the segment (its line beyond the ends is no edge).
          const double u = std::clamp(((px - s[0][0]) * dx + (py - s[0][1]) * dy) / (len * len), 0.0, 1.0);
          best = std::min(best, std::hypot(px - s[0][0] - u * dx, py - s[0][1] - u * dy));
        }
    }
  return best;
}

// Camera scene: an icosphere with per-vertex colours seen through look_at / perspective.
struct Scene {
  Tensor positions, colours, eye, fov, triangles;
  int w = 28, h = 24;
};
Scene make_scene(int subdivisions, int w, int h) {
  raster::Mesh mesh = raster::make_icosphere(subdivisions, 0.8f);
  Scene s;
  s.positions = cast(mesh.positions, DType::Float64).set_requires_grad();
  s.colours = Tensor::uniform({mesh.num_vertices(), 3}, 0.1, 0.9, 77, DType::Float64).set_requires_grad();
  s.eye = Tensor::from_values({0.3, 0.4, 2.6}, {3}, DType::Float64).set_requires_grad();
  s.fov = Tensor::scalar(0.9, DType::Float64).set_requires_grad();
  s.triangles = mesh.triangles;
  s.w = w;
  s.h = h;
  return s;
}
Tensor camera_clip(const Scene& s, const Tensor& positions, const Tensor& eye, const Tensor& fov) {
  Tensor target = Tensor::zeros({3}, eye.dtype());
  Tensor up = Tensor::from_values({0, 1, 0}, {3}, eye.dtype());
  Tensor mvp = matmul(perspective(fov, double(s.w) / s.h, 0.5, 10.0), look_at(eye, target, up));
  return transform_points(positions, mvp);
}
// rasterize -> interpolate colours -> antialias.
Tensor render_aa(const Tensor& clip, const Tensor& colours, const Tensor& tris, int w, int h,
                 const AntialiasOptions& options = {}) {
  GBuffer gb = rasterize(clip, tris, {w, h});
  return antialias(interpolate(colours, gb, tris), gb, clip, tris, options);
}

// A square of constant colour (0.9, 0.6, 0.3) over black, shifted right by dx pixels.
Tensor square_clip(double dx_pixels, int W, int H) {
  const double sx = 2.0 * dx_pixels / W;
  (void)H;
  const double x0 = -0.43 + sx, x1 = 0.31 + sx, y0 = -0.37, y1 = 0.42;
  return Tensor::from_values({x0, y0, 0, 1, x1, y0, 0, 1, x1, y1, 0, 1, x0, y1, 0, 1}, {4, 4}, DType::Float64);
}
Tensor square_triangles() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 0, 2, 3}, {2, 3}); }
Tensor square_colours() {
  return Tensor::from_values({0.9, 0.6, 0.3, 0.9, 0.6, 0.3, 0.9, 0.6, 0.3, 0.9, 0.6, 0.3}, {4, 3}, DType::Float64);
}
// The square rendered with its constant colour, optionally antialiased.
Tensor render_square(const Tensor& clip, int W, int H, bool aa) {
  Tensor tris = square_triangles();
  GBuffer gb = rasterize(clip, tris, {W, H});
  Tensor img = interpolate(square_colours(), gb, tris);
  return aa ? antialias(img, gb, clip, tris) : img;
}

}  // namespace

TEST_CASE("antialias: gradients w.r.t. the image and the clip positions match finite differences",
          "[ops][antialias][gradcheck]") {
  const int W = 24, H = 20;
  Tensor clip = two_triangles_clip().set_requires_grad();
  Tensor tris = two_triangles();
  Tensor image = gr::testing::random_input({H, W, 3}, 0.0, 1.0, 91);
  // Steps of up to 2 eps = 6e-5 in clip move edges by < 1e-3 px: no pixel centre
  // or mid-point (where the blend switches pixel) is that close to an edge.
  REQUIRE(edge_margin(clip, tris, W, H) > 5e-3);
  raster::AntialiasStats stats;
  AntialiasOptions opt;
  opt.stats = &stats;
  {
    NoGradGuard ng;
    antialias(image, rasterize(clip, tris, {W, H}), clip, tris, opt);
  }
  CHECK(stats.blended_pairs > 20);
  auto f = [&](const Inputs& in) { return antialias(in[0], rasterize(in[1], tris, {W, H}), in[1], tris); };
  require_gradcheck("antialias (image, clip)", f, {image, clip}, GradcheckOptions{3e-5});
}

TEST_CASE("antialias: rasterize -> interpolate -> antialias gradients w.r.t. clip match finite differences",
          "[ops][antialias][gradcheck]") {
  const int W = 24, H = 20;
  Tensor clip = two_triangles_clip().set_requires_grad();
  Tensor tris = two_triangles();
  Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 17);
  REQUIRE(edge_margin(clip, tris, W, H) > 5e-3);  // as above: steps move edges < 1e-3 px
  require_gradcheck("antialias chain (clip, colours)",
                    [&](const Inputs& in) { return render_aa(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{3e-5});
}

TEST_CASE("antialias: gradients on edges owned by horizontal and by vertical pixel pairs match finite differences",
          "[ops][antialias][gradcheck]") {
  // Two overlapping triangles (the second nearer: a silhouette over a surface and
  // over the background). Edge angles from vertical: 14-15 deg (owned by horizontal
  // pairs) and 60-72 deg (owned by vertical pairs), none near the 45 deg switch.
  const int W = 32, H = 28;
  Tensor clip = Tensor::from_values({-0.51, -0.58, 0.1, 1.0, -0.24, 0.69, 0.1, 1.0, 0.73, 0.13, 0.1, 1.0,
                                     0.04, -0.81, -0.2, 1.0, 0.62, -0.43, -0.2, 1.0, -0.11, -0.15, -0.2, 1.0},
                                    {6, 4}, DType::Float64)
                     .set_requires_grad();
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  Tensor colours = gr::testing::random_input({6, 3}, 0.1, 0.9, 29);
  REQUIRE(edge_margin(clip, tris, W, H) > 5e-3);  // steps of 6e-5 in clip move edges < 1e-3 px
  raster::AntialiasStats stats;
  AntialiasOptions opt;
  opt.stats = &stats;
  {
    NoGradGuard ng;
    render_aa(clip, colours, tris, W, H, opt);
  }
  CHECK(stats.blended_pairs > 30);
  require_gradcheck("antialias slanted edges (clip, colours)",
                    [&](const Inputs& in) { return render_aa(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{3e-5});
}

TEST_CASE("antialias: gradients reach model-space vertices, eye and fov through transform_points",
          "[ops][antialias][gradcheck]") {
  Scene s = make_scene(1, 28, 24);
  {
    // About 10 px per world unit here: steps of 2 eps = 2e-5 move points by ~2e-4 px.
    NoGradGuard ng;
    REQUIRE(edge_margin(camera_clip(s, s.positions, s.eye, s.fov), s.triangles, s.w, s.h) > 6e-4);
  }
  AntialiasOptions opt;
  opt.topology = antialias_topology(s.triangles, s.positions);
  require_gradcheck(
      "antialias model space (positions, colours, eye, fov)",
      [&](const Inputs& in) {
        return render_aa(camera_clip(s, in[0], in[2], in[3]), in[1], s.triangles, s.w, s.h, opt);
      },
      {s.positions, s.colours, s.eye, s.fov}, GradcheckOptions{1e-5});
}

TEST_CASE("antialias: a translating silhouette gets correctly signed position gradients where interior ones vanish",
          "[ops][antialias]") {
  const int W = 16, H = 14;
  Tensor target;
  {
    NoGradGuard ng;
    target = render_square(square_clip(0.3, W, H), W, H, true);  // the square 0.3 px to the right
  }
  auto loss_of = [&](const Tensor& clip, bool aa) {
    Tensor d = render_square(clip, W, H, aa) - target;
    return sum(d * d);
  };
  // Without antialiasing: constant colour, so the x gradients are exactly zero.
  Tensor clip = square_clip(0.0, W, H).set_requires_grad();
  backward(loss_of(clip, false));
  REQUIRE(clip.grad().defined());
  for (std::int64_t i = 0; i < 4; ++i) CHECK(clip.grad().at({i, 0}) == 0.0);
  // With antialiasing: every vertex is pulled to the right (dL/dx < 0).
  clip.zero_grad();
  Tensor loss = loss_of(clip, true);
  backward(loss);
  Tensor g = clip.grad();
  REQUIRE(all_finite(g));
  for (std::int64_t i = 0; i < 4; ++i) {
    INFO("vertex " << i);
    CHECK(g.at({i, 0}) < 0.0);
  }
  // A small step along -grad lowers the loss.
  std::vector<double> c = clip.to_vector(), gv = g.to_vector();
  for (std::size_t k = 0; k < c.size(); ++k) c[k] -= 1e-3 * gv[k];
  Tensor stepped = Tensor::from_values(c, {4, 4}, DType::Float64);
  NoGradGuard ng;
  CHECK(loss_of(stepped, true).item() < loss.item());
}

TEST_CASE("antialias: interior edges of a closed mesh are not blended, only the silhouette against background",
          "[ops][antialias]") {
  for (bool welded_copies : {false, true}) {
    // Icosphere (shared vertices), or a UV sphere whose seam vertices are duplicated.
    raster::Mesh mesh = welded_copies ? raster::make_uv_sphere(12, 16, 0.8f) : raster::make_icosphere(3, 0.8f);
    Scene s = make_scene(0, 64, 56);
    NoGradGuard ng;
    Tensor clip = camera_clip(s, cast(mesh.positions, DType::Float64), s.eye, s.fov);
    GBuffer gb = rasterize(clip, mesh.triangles, {s.w, s.h});
    Tensor image = Tensor::uniform({s.h, s.w, 3}, 0.0, 1.0, 5, DType::Float64);
    raster::AntialiasStats stats;
    AntialiasOptions opt;
    opt.stats = &stats;
    Tensor out = antialias(image, gb, clip, mesh.triangles, opt);
    INFO((welded_copies ? "uv sphere" : "icosphere"));
    CHECK(stats.blended_pairs > 50);
    CHECK(stats.candidate_pairs > 4 * stats.blended_pairs);  // most tri_id changes are interior
    // A pixel none of whose 4 neighbours is background is unchanged.
    std::int64_t unchanged = 0, checked = 0;
    for (int y = 0; y < s.h; ++y)
      for (int x = 0; x < s.w; ++x) {
        bool near_bg = gb.tri_id.at({y, x}) == 0;
        for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int xx = x + dx, yy = y + dy;
          if (xx >= 0 && yy >= 0 && xx < s.w && yy < s.h && gb.tri_id.at({yy, xx}) == 0) near_bg = true;
        }
        if (near_bg) continue;
        ++checked;
        bool same = true;
        for (std::int64_t c = 0; c < 3; ++c) same &= out.at({y, x, c}) == image.at({y, x, c});
        unchanged += same;
      }
    CHECK(checked > 500);
    CHECK(unchanged == checked);
    // Index-only topology: the UV sphere's seam becomes a false silhouette.
    if (welded_copies) {
      raster::AntialiasStats by_index;
      opt.topology = antialias_topology(mesh.triangles);
      opt.stats = &by_index;
      antialias(image, gb, clip, mesh.triangles, opt);
      CHECK(by_index.blended_pairs > stats.blended_pairs);
      opt.topology = antialias_topology(mesh.triangles, mesh.positions);
      antialias(image, gb, clip, mesh.triangles, opt);
      CHECK(by_index.blended_pairs == stats.blended_pairs);
    }
  }
}

TEST_CASE("antialias: image and gradients are bit-identical for 1 and 2 threads", "[ops][antialias][determinism]") {
  Scene s = make_scene(3, 96, 80);
  auto run = [&](int threads, DType dtype) {
    set_num_threads(threads);
    Tensor pos = cast(s.positions.detach(), dtype).set_requires_grad();
    Tensor col = cast(s.colours.detach(), dtype).set_requires_grad();
    Tensor eye = cast(s.eye.detach(), dtype), fov = cast(s.fov.detach(), dtype);
    Tensor clip = camera_clip(s, pos, eye, fov);
    Tensor img = render_aa(clip, col, s.triangles, s.w, s.h);
    backward(sum(img * img));
    std::vector<double> r = img.to_vector();
    for (const Tensor& t : {pos.grad(), col.grad()})
      for (double x : t.to_vector()) r.push_back(x);
    return r;
  };
  for (DType dtype : {DType::Float64, DType::Float32}) {
    const auto one = run(1, dtype);
    const auto two = run(2, dtype);
    CHECK(one == two);
  }
  set_num_threads(0);
}

TEST_CASE("antialias: float32 agrees with float64", "[ops][antialias]") {
  Scene s = make_scene(2, 48, 40);
  NoGradGuard ng;
  Tensor clip = camera_clip(s, s.positions, s.eye, s.fov);
  Tensor a = render_aa(clip, s.colours, s.triangles, s.w, s.h);
  Tensor b = render_aa(cast(clip, DType::Float32), cast(s.colours, DType::Float32), s.triangles, s.w, s.h);
  CHECK(b.dtype() == DType::Float32);
  std::vector<double> va = a.to_vector(), vb = b.to_vector();
  double worst = 0;
  for (std::size_t i = 0; i < va.size(); ++i) worst = std::max(worst, std::abs(va[i] - vb[i]));
  CHECK(worst < 1e-4);
}

TEST_CASE("antialias: zero incoming gradient gives zero gradients and no NaN", "[ops][antialias]") {
  Tensor clip = two_triangles_clip().set_requires_grad();
  Tensor tris = two_triangles();
  Tensor image = gr::testing::random_input({20, 24, 3}, 0.0, 1.0, 3);
  Tensor out = antialias(image, rasterize(clip, tris, {24, 20}), clip, tris);
  backward(out, Tensor::zeros(out.shape(), DType::Float64));
  for (double x : clip.grad().to_vector()) CHECK(x == 0.0);
  for (double x : image.grad().to_vector()) CHECK(x == 0.0);
}

TEST_CASE("antialias: bad arguments throw with messages naming the argument", "[ops][antialias]") {
  Tensor clip = two_triangles_clip();
  Tensor tris = two_triangles();
  GBuffer gb = rasterize(clip, tris, {24, 20});
  Tensor image = Tensor::zeros({20, 24, 3}, DType::Float64);
  auto throws = [&](auto&& call, const std::string& needle) {
    try {
      call();
      FAIL("no exception; expected one mentioning " << needle);
    } catch (const Error& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(needle) != std::string::npos);
    }
  };
  throws([&] { antialias(Tensor::zeros({20, 24}, DType::Float64), gb, clip, tris); }, "'image'");
  throws([&] { antialias(Tensor::zeros({20, 24, 3}, DType::Float32), gb, clip, tris); }, "'image'");
  throws([&] { antialias(Tensor::zeros({20, 25, 3}, DType::Float64), gb, clip, tris); }, "'gbuffer'");
  throws([&] { antialias(image, GBuffer{}, clip, tris); }, "'gbuffer'");
  throws([&] { antialias(image, gb, Tensor::zeros({6, 3}, DType::Float64), tris); }, "'clip'");
  throws([&] { antialias(image, gb, clip, cast(tris, DType::Float32)); }, "'triangles'");
  throws([&] { antialias(image, gb, clip.detach(), Tensor::from_vector<std::int32_t>({0, 1, 9}, {1, 3})); }, "tris[0][2]");
  AntialiasOptions opt;
  opt.topology = antialias_topology(Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3}));
  throws([&] { antialias(image, gb, clip, tris, opt); }, "'topology'");
  CHECK_THROWS_AS(antialias(image, gb, clip, tris, opt), ValueError);
  CHECK_THROWS_AS(antialias_topology(tris, Tensor::zeros({4}, DType::Float64)), ShapeError);
  // A G-buffer whose ids go beyond the triangles, an empty image, bad indices for the topology.
  GBuffer bad_ids = gb;
  bad_ids.tri_id = gb.tri_id.copy();
  bad_ids.tri_id.data<std::int32_t>()[3] = int(tris.size(0)) + 1;
  throws([&] { antialias(image, bad_ids, clip, tris); }, "tri_id[3]");
  CHECK_THROWS_AS(antialias(image, bad_ids, clip, tris), IndexError);
  GBuffer empty = gb;
  empty.tri_id = Tensor::zeros({20, 0}, DType::Int32);
  empty.depth = Tensor::zeros({20, 0}, DType::Float64);
  CHECK_THROWS_AS(antialias(Tensor::zeros({20, 0, 3}, DType::Float64), empty, clip, tris), ValueError);
  const Tensor bad_tri = Tensor::from_vector<std::int32_t>({0, 1, 7}, {1, 3});
  CHECK_THROWS_AS(antialias_topology(bad_tri, Tensor::zeros({3, 2}, DType::Float64)), IndexError);
  CHECK_THROWS_AS(antialias_topology(Tensor::from_vector<std::int32_t>({0, -1, 2}, {1, 3})), IndexError);
  Tensor nan_positions = Tensor::zeros({3, 2}, DType::Float64);
  nan_positions.data<double>()[4] = std::nan("");
  throws([&] { antialias_topology(Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3}), nan_positions); },
         "positions[4]");
}

// The process's peak resident memory so far, in KiB.
long peak_rss_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

TEST_CASE("antialias_topology without positions: huge indices cost memory by triangles and pair the same edges",
          "[ops][antialias]") {
  // A closed tetrahedron with vertices 0..3, and the same with its vertices
  // numbered far apart (in the same order), up to 2^31 - 1.
  const std::vector<std::int32_t> dense = {0, 1, 2, 0, 3, 1, 1, 3, 2, 2, 3, 0};
  const std::int32_t far[4] = {5, 1000003, 100000000, INT32_MAX};
  std::vector<std::int32_t> sparse;
  for (std::int32_t i : dense) sparse.push_back(far[i]);
  const long before = peak_rss_kib();
  AntialiasTopology a = antialias_topology(Tensor::from_vector<std::int32_t>(dense, {4, 3}));
  AntialiasTopology b = antialias_topology(Tensor::from_vector<std::int32_t>(sparse, {4, 3}));
  CHECK(peak_rss_kib() - before < 16 * 1024);
  CHECK(a->neighbour() == b->neighbour());
  CHECK(std::count(a->neighbour().begin(), a->neighbour().end(), raster::kBoundaryEdge) == 0);  // closed
  // And what they take is checked against the memory budget first.
  const Tensor many = Tensor::zeros({20000, 3}, DType::Int32);
  {
    struct TightLimit {  // 1 MiB to spare; the default again on leaving
      TightLimit() { set_memory_limit(memory_in_use() + (1 << 20)); }
      ~TightLimit() { set_memory_limit(0); }
    } limit;
    CHECK_THROWS_AS(antialias_topology(many), MemoryError);
  }
  CHECK(antialias_topology(many)->num_tris() == 20000);
}

TEST_CASE("antialias: pos_gradient_boost scales the clip gradient exactly and leaves the image gradient and output alone",
          "[ops][antialias]") {
  const int W = 24, H = 20;
  Tensor clip = two_triangles_clip().set_requires_grad();
  Tensor tris = two_triangles();
  Tensor image = gr::testing::random_input({H, W, 3}, 0.0, 1.0, 91).set_requires_grad();
  Tensor weights = gr::testing::random_input({H, W, 3}, -1.0, 1.0, 92);
  const double factor = 3.7;
  std::vector<double> out[2], g_clip[2], g_image[2];
  for (int boosted = 0; boosted < 2; ++boosted) {
    AntialiasOptions opt;
    if (boosted) opt.pos_gradient_boost = factor;
    clip.zero_grad();
    image.zero_grad();
    Tensor o = antialias(image, rasterize(clip, tris, {W, H}), clip, tris, opt);
    backward(sum(o * weights));
    out[boosted] = o.to_vector();
    g_clip[boosted] = clip.grad().to_vector();
    g_image[boosted] = image.grad().to_vector();
  }
  CHECK(out[1] == out[0]);
  CHECK(g_image[1] == g_image[0]);
  int moved = 0;
  for (std::size_t i = 0; i < g_clip[0].size(); ++i) {
    CHECK(g_clip[1][i] == factor * g_clip[0][i]);
    moved += g_clip[0][i] != 0;
  }
  CHECK(moved > 0);
  AntialiasOptions bad;
  bad.pos_gradient_boost = std::nan("");
  CHECK_THROWS_WITH(antialias(image, rasterize(clip, tris, {W, H}), clip, tris, bad),
                    Catch::Contains("pos_gradient_boost"));
}

TEST_CASE("antialias: gradients at a silhouette through a row of pixel centres match finite differences",
          "[ops][antialias][gradcheck]") {
  // A flat-coloured triangle over the background whose top edge runs exactly
  // along the centres of row 5 (screen y 5.5); its vertices lie outside the
  // image, so the edge is the only boundary and no corner is near a centre
  // (at a corner, a centre changing sides is a jump of the first-order blend).
  const int W = 16, H = 16;
  const double y = 1.0 - 2.0 * 5.5 / H;
  Tensor clip = Tensor::from_values({-4, y, 0.1, 1.0, 4, y, 0.1, 1.0, 0.05, -9, 0.1, 1.0}, {3, 4}, DType::Float64)
                    .set_requires_grad();
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  Tensor colours = Tensor::from_values({0.8, 0.3, 0.2, 0.8, 0.3, 0.2, 0.8, 0.3, 0.2}, {3, 3}, DType::Float64)
                       .set_requires_grad();
  raster::AntialiasStats stats;
  AntialiasOptions opt;
  opt.stats = &stats;
  {
    NoGradGuard ng;
    render_aa(clip, colours, tris, W, H, opt);
  }
  CHECK(stats.blended_pairs == W);  // one vertical pair per column
  require_gradcheck("antialias silhouette through pixel centres (clip, colours)",
                    [&](const Inputs& in) { return render_aa(in[0], in[1], tris, W, H); }, {clip, colours},
                    GradcheckOptions{1e-6});
}

TEST_CASE("antialias: the G-buffer's kept projection gives the bits of projecting clip again, and only for that clip",
          "[ops][antialias]") {
  Scene s = make_scene(3, 96, 80);
  NoGradGuard ng;
  for (DType dtype : {DType::Float64, DType::Float32}) {
    INFO("dtype " << (dtype == DType::Float32 ? "float32" : "float64"));
    const Tensor clip = cast(camera_clip(s, s.positions, s.eye, s.fov), dtype);
    const Tensor col = cast(s.colours, dtype);
    GBuffer gb = rasterize(clip, s.triangles, {s.w, s.h});
    REQUIRE(gb.projection);
    CHECK(detail::projection_of(gb, clip, s.w, s.h) != nullptr);
    CHECK(detail::projection_of(gb, clip, s.w + 1, s.h) == nullptr);
    CHECK(detail::projection_of(gb, clip.copy(), s.w, s.h) == nullptr);  // equal values, another tensor
    const Tensor image = interpolate(col, gb, s.triangles);
    const std::vector<double> kept = antialias(image, gb, clip, s.triangles).to_vector();
    GBuffer own = gb;
    own.projection.reset();
    const std::vector<double> projected = antialias(image, own, clip, s.triangles).to_vector();
    CHECK(kept == projected);
    CHECK(std::memcmp(kept.data(), projected.data(), kept.size() * sizeof(double)) == 0);
    // Written in place since (the same values): not the tensor projected any more.
    Tensor written = clip;
    if (dtype == DType::Float32)
      written.data<float>();
    else
      written.data<double>();
    CHECK(detail::projection_of(gb, clip, s.w, s.h) == nullptr);
    CHECK(antialias(image, gb, clip, s.triangles).to_vector() == kept);
  }
}

TEST_CASE("antialias: a G-buffer of more than kKeptProjectionVertices vertices keeps no projection and antialias "
          "projects clip itself",
          "[ops][antialias]") {
  NoGradGuard ng;
  // One triangle over the image; the other vertices unused.
  const std::int64_t n = detail::kKeptProjectionVertices + 1;
  std::vector<double> rows(static_cast<std::size_t>(4 * n), 0.0);
  const double corners[3][4] = {{-0.9, -0.8, 0.1, 1.0}, {0.85, -0.7, 0.2, 1.0}, {-0.1, 0.9, 0.3, 1.0}};
  for (std::int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 4; ++k) rows[static_cast<std::size_t>(4 * i + k)] = corners[i % 3][k];
  const Tensor clip = Tensor::from_values(rows, {n, 4}, DType::Float64);
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3});
  GBuffer gb = rasterize(clip, tris, {20, 16});
  CHECK_FALSE(gb.projection);
  const Tensor image = Tensor::ones({16, 20, 1}, DType::Float64);
  const Tensor out = antialias(image, gb, clip, tris);
  CHECK(out.shape() == image.shape());
  CHECK(all_finite(out));
}
