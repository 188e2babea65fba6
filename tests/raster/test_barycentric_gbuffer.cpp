// nvdiffrast-layout G-buffer and interpolation kernels (raster/barycentric_*):
// the barycentrics, z/w and derivatives of each pixel ray's linear system
// (tests/ops/pixel_ray.h), and adjoints equal to central differences of the forward.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <random>
#include <vector>

#include "../ops/clip_scenes.h"
#include "../ops/pixel_ray.h"
#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "raster/barycentric_gbuffer.h"
#include "raster/barycentric_interpolate.h"
#include "raster/rasterize.h"

using namespace gr;

namespace {

constexpr int W = 24, H = 20;

struct Scene {
  std::vector<double> clip;
  std::vector<std::int32_t> tris;
  std::vector<std::int32_t> tri_id;  // rasterize_forward's coverage
  raster::BarycentricGBufferParams<double> params() const {
    return {clip.data(), static_cast<std::int64_t>(clip.size() / 4), tris.data(),
            static_cast<std::int64_t>(tris.size() / 3), W, H};
  }
};

Scene make_scene(std::vector<double> clip, std::vector<std::int32_t> tris) {
  Scene s{std::move(clip), std::move(tris), std::vector<std::int32_t>(W * H)};
  raster::RasterParams<double> p;
  p.clip = s.clip.data();
  p.num_vertices = static_cast<std::int64_t>(s.clip.size() / 4);
  p.tris = s.tris.data();
  p.num_tris = static_cast<std::int64_t>(s.tris.size() / 3);
  p.settings.width = W;
  p.settings.height = H;
  std::vector<double> uv(2 * W * H), depth(W * H);
  raster::rasterize_forward(p, s.tri_id.data(), uv.data(), depth.data());
  return s;
}

Scene two_triangles() { return make_scene(testing::two_triangles_clip().to_vector(), {0, 1, 2, 3, 4, 5}); }

// A triangle crossing the near plane (one vertex behind the camera) and one close to w = 0.
Scene near_plane() {
  return make_scene({-0.6, -0.5, 0.2, 1.0, 0.7, -0.4, 0.1, 0.9, 0.05, 0.3, -0.4, -0.3, 0.4, 0.6, 0.0, 0.05},
                    {0, 1, 2, 0, 1, 3});
}

std::vector<double> random_weights(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-1, 1);
  std::vector<double> w(n);
  for (double& x : w) x = d(rng);
  return w;
}

// Worst |analytic - central difference| / max(1, |numeric|) over the inputs.
double worst_gradient_error(std::vector<double>& x, const std::vector<double>& analytic,
                            const std::function<double()>& loss) {
  double worst = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double keep = x[i], h = 1e-6;
    x[i] = keep + h;
    const double up = loss();
    x[i] = keep - h;
    const double down = loss();
    x[i] = keep;
    const double numeric = (up - down) / (2 * h);
    worst = std::max(worst, std::abs(analytic[i] - numeric) / std::max(1.0, std::abs(numeric)));
  }
  return worst;
}

}  // namespace

TEST_CASE("barycentric gbuffer: b0, b1, z/w and their pixel derivatives solve each pixel ray's linear system",
          "[rasterize]") {
  for (const Scene& s : {two_triangles(), near_plane()}) {
    std::vector<double> rast(4 * W * H), db(4 * W * H);
    raster::barycentric_gbuffer_forward(s.params(), s.tri_id.data(), 0, rast.data(), db.data());
    auto ray = [&](int tri, double px, double py) {
      return testing::pixel_ray(s.clip, s.tris, tri, testing::ndc_x(px, W), testing::ndc_y(py, H));
    };
    int covered = 0;
    for (int q = 0; q < W * H; ++q) {
      REQUIRE(rast[4 * q + 3] == s.tri_id[q]);
      if (s.tri_id[q] == 0) continue;
      ++covered;
      const int tri = s.tri_id[q] - 1;
      const double x = q % W + 0.5, y = q / W + 0.5, h = 1e-4;
      const testing::PixelRay r = ray(tri, x, y);
      CHECK(rast[4 * q] == Approx(r.b[0]).margin(1e-12));
      CHECK(rast[4 * q + 1] == Approx(r.b[1]).margin(1e-12));
      CHECK(rast[4 * q + 2] == Approx(r.zw).margin(1e-12));
      for (int k = 0; k < 2; ++k) {
        CHECK(db[4 * q + 2 * k] == Approx((ray(tri, x + h, y).b[k] - ray(tri, x - h, y).b[k]) / (2 * h)).margin(1e-7));
        CHECK(db[4 * q + 2 * k + 1] ==
              Approx((ray(tri, x, y + h).b[k] - ray(tri, x, y - h).b[k]) / (2 * h)).margin(1e-7));
      }
    }
    CHECK(covered > 20);
  }
}

TEST_CASE("barycentric gbuffer: clip positions scaled by 2^-330 or 2^330 give the same values and derivatives",
          "[rasterize]") {
  // The same points in homogeneous coordinates. An audit's finding: db
  // divided by S^2, which under- or overflows at these scales (S ~ scale^2),
  // so every derivative came out 0 (or saturated) instead of the unscaled one.
  for (const Scene& s : {two_triangles(), near_plane()}) {
    std::vector<double> rast(4 * W * H), db(4 * W * H);
    raster::barycentric_gbuffer_forward(s.params(), s.tri_id.data(), 0, rast.data(), db.data());
    for (const double scale : {0x1p-330, 0x1p330}) {
      Scene scaled = s;
      for (double& x : scaled.clip) x *= scale;
      std::vector<double> rast_s(4 * W * H), db_s(4 * W * H);
      raster::barycentric_gbuffer_forward(scaled.params(), s.tri_id.data(), 0, rast_s.data(), db_s.data());
      CHECK(rast_s == rast);  // powers of two: the same roundings
      for (int i = 0; i < 4 * W * H; ++i) {
        INFO("db[" << i << "] = " << db[i] << ", scaled " << db_s[i] << ", scale " << scale);
        REQUIRE(db_s[i] == Approx(db[i]).epsilon(1e-12).margin(1e-14));
      }
    }
  }
}

TEST_CASE("barycentric gbuffer: the adjoint equals central differences, also across the near plane",
          "[rasterize]") {
  for (Scene s : {two_triangles(), near_plane()}) {
    const std::vector<double> wr = random_weights(4 * W * H, 1), wd = random_weights(4 * W * H, 2);
    std::vector<double> rast(4 * W * H), db(4 * W * H);
    auto loss = [&] {
      raster::barycentric_gbuffer_forward(s.params(), s.tri_id.data(), 0, rast.data(), db.data());
      double l = 0;
      for (int i = 0; i < 4 * W * H; ++i) l += (i % 4 == 3 ? 0.0 : wr[i] * rast[i]) + wd[i] * db[i];
      return l;
    };
    loss();
    std::vector<double> grad(s.clip.size(), 0.0);
    std::vector<double> g_rast(wr);
    for (int q = 0; q < W * H; ++q) g_rast[4 * q + 3] = 0;
    raster::barycentric_gbuffer_backward(s.params(), rast.data(), g_rast.data(), wd.data(), grad.data());
    CHECK(worst_gradient_error(s.clip, grad, loss) < 1e-7);
  }
}

TEST_CASE("barycentric interpolate: the adjoint to attributes, barycentrics and their derivatives equals central "
          "differences",
          "[interpolate]") {
  const Scene s = near_plane();
  std::vector<double> rast(4 * W * H), db(4 * W * H);
  raster::barycentric_gbuffer_forward(s.params(), s.tri_id.data(), 0, rast.data(), db.data());
  std::vector<double> attr = random_weights(4 * 3, 3);
  const std::vector<std::int32_t> diff = {0, 2};
  const std::vector<double> w_out = random_weights(3 * W * H, 4), w_da = random_weights(4 * W * H, 5);
  raster::BarycentricInterpolateParams<double> p{attr.data(), 4, 3, s.tris.data(), 2, rast.data(), W * H,
                                                 db.data(), diff.data(), 2};
  std::vector<double> out(3 * W * H), da(4 * W * H);
  auto loss = [&] {
    raster::barycentric_interpolate_forward(p, out.data(), da.data());
    double l = 0;
    for (int i = 0; i < 3 * W * H; ++i) l += w_out[i] * out[i];
    for (int i = 0; i < 4 * W * H; ++i) l += w_da[i] * da[i];
    return l;
  };
  std::vector<double> g_attr(attr.size(), 0.0), g_rast(rast.size(), 0.0), g_db(db.size(), 0.0);
  raster::barycentric_interpolate_backward(p, w_out.data(), w_da.data(), {g_attr.data(), g_rast.data(), g_db.data()});
  CHECK(worst_gradient_error(attr, g_attr, loss) < 1e-8);
  // Only u and v of covered pixels are inputs (z/w and the id are not read).
  for (int q = 0; q < W * H; ++q) {
    CHECK(g_rast[4 * q + 2] == 0.0);
    if (rast[4 * q + 3] == 0) {
      CHECK(g_rast[4 * q] == 0.0);
      g_rast[4 * q] = g_rast[4 * q + 1] = 0;
    }
  }
  std::vector<double> uv_grad(g_rast);
  for (int q = 0; q < W * H; ++q) uv_grad[4 * q + 3] = 0;
  std::vector<double> rast_in(rast);
  auto loss_rast = [&] {
    for (int q = 0; q < W * H; ++q)
      for (int c = 0; c < 2; ++c) rast[4 * q + c] = rast_in[4 * q + c];
    return loss();
  };
  for (int q = 0; q < W * H; ++q) rast_in[4 * q + 2] = rast[4 * q + 2], rast_in[4 * q + 3] = rast[4 * q + 3];
  CHECK(worst_gradient_error(rast_in, uv_grad, loss_rast) < 1e-8);
  CHECK(worst_gradient_error(db, g_db, loss) < 1e-8);
}

TEMPLATE_TEST_CASE("barycentric interpolate: the values without derivatives (16 pixels in vector lanes) equal the "
                   "per-pixel blend's bit for bit",
                   "[interpolate]", float, double) {
  using T = TestType;
  const Scene s = two_triangles();
  std::vector<double> rast64(4 * W * H), db64(4 * W * H);
  raster::barycentric_gbuffer_forward(s.params(), s.tri_id.data(), 0, rast64.data(), db64.data());
  const std::vector<T> rast(rast64.begin(), rast64.end()), db(db64.begin(), db64.end());
  for (int C = 1; C <= 5; ++C) {
    const std::vector<double> a64 = random_weights(6 * static_cast<std::size_t>(C), 7 + C);
    const std::vector<T> attr(a64.begin(), a64.end());
    const std::vector<std::int32_t> diff = {0};
    // A pixel count that leaves a partial batch of lanes.
    const std::int64_t pixels = W * H - 5;
    raster::BarycentricInterpolateParams<T> p{attr.data(), 6, C, s.tris.data(), 2, rast.data(), pixels,
                                              db.data(), diff.data(), 1};
    std::vector<T> lanes(C * pixels, T(-7)), per_pixel(C * pixels, T(-9)), da(2 * pixels);
    raster::barycentric_interpolate_forward(p, lanes.data(), static_cast<T*>(nullptr));
    raster::barycentric_interpolate_forward(p, per_pixel.data(), da.data());  // derivatives: the per-pixel loop
    int covered = 0;
    for (std::int64_t q = 0; q < pixels; ++q) {
      covered += rast[4 * q + 3] != 0;
      for (int c = 0; c < C; ++c) {
        const std::int64_t i = q * C + c;
        REQUIRE(std::memcmp(&lanes[i], &per_pixel[i], sizeof(T)) == 0);
        // And the blend itself, evaluated here independently.
        double want = 0;
        if (rast[4 * q + 3] != 0) {
          const std::int32_t* t = s.tris.data() + 3 * (static_cast<std::int64_t>(rast[4 * q + 3]) - 1);
          const double b0 = rast[4 * q], b1 = rast[4 * q + 1];
          want = b0 * attr[t[0] * C + c] + b1 * attr[t[1] * C + c] + (1 - b0 - b1) * attr[t[2] * C + c];
        }
        REQUIRE(std::abs(lanes[i] - want) <= 1e-6 * std::max(1.0, std::abs(want)));
      }
    }
    CHECK(covered > 0);
    CHECK(covered < pixels);
  }
}

namespace {

// A jittered n x n grid of vertices over a w x h image (varied w, so the
// barycentrics are perspective-correct), rasterized: every triangle shares
// its vertices with up to five others.
struct GridScene {
  int w = 0, h = 0;
  std::vector<float> clip;
  std::vector<std::int32_t> tris, tri_id;
};

GridScene grid_scene(int w, int h, int n) {
  GridScene s{w, h, {}, {}, std::vector<std::int32_t>(static_cast<std::size_t>(w) * h)};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f), depth(-0.5f, 0.5f), ww(0.8f, 1.6f);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const float wk = ww(rng), cell = 2.2f / (n - 1);
      const float x = -1.1f + cell * (i + (i > 0 && i < n - 1 ? jitter(rng) : 0.0f));
      const float y = -1.1f + cell * (j + (j > 0 && j < n - 1 ? jitter(rng) : 0.0f));
      s.clip.insert(s.clip.end(), {x * wk, y * wk, depth(rng) * wk, wk});
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const std::int32_t v = j * n + i;
      s.tris.insert(s.tris.end(), {v, v + 1, v + n, v + 1, v + n + 1, v + n});
    }
  raster::RasterParams<float> p;
  p.clip = s.clip.data();
  p.num_vertices = n * n;
  p.tris = s.tris.data();
  p.num_tris = static_cast<std::int64_t>(s.tris.size() / 3);
  p.settings.width = w;
  p.settings.height = h;
  std::vector<float> uv(2 * s.tri_id.size()), z(s.tri_id.size());
  raster::rasterize_forward(p, s.tri_id.data(), uv.data(), z.data());
  return s;
}

}  // namespace

TEST_CASE("barycentric adjoints: gradients to attributes, barycentrics and clip are the same bits for 1, 2 and 8 "
          "threads and equal per-pixel sums in float64",
          "[interpolate][rasterize][determinism]") {
  // 256 x 192 pixels: several pixel ranges when grouping by triangle, many triangle chunks.
  const GridScene s = grid_scene(256, 192, 41);
  const std::int64_t P = static_cast<std::int64_t>(s.w) * s.h, N = 41 * 41, M = static_cast<std::int64_t>(s.tris.size() / 3);
  raster::BarycentricGBufferParams<float> gp{s.clip.data(), N, s.tris.data(), M, s.w, s.h};
  std::vector<float> rast(4 * P), db(4 * P);
  raster::barycentric_gbuffer_forward(gp, s.tri_id.data(), 0, rast.data(), db.data());
  const int C = 3;
  std::vector<float> attr(N * C), g_out(P * C), g_da(P * 2), g_rast(4 * P), g_db(4 * P);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> d(-1, 1);
  for (auto* v : {&attr, &g_out, &g_da, &g_rast, &g_db})
    for (float& x : *v) x = d(rng);
  for (std::int64_t q = 0; q < P; q += 7) g_rast[4 * q] = g_rast[4 * q + 1] = g_rast[4 * q + 2] = 0;  // some skipped
  const std::int32_t diff[] = {1};
  raster::BarycentricInterpolateParams<float> ip{attr.data(), N, C, s.tris.data(), M, rast.data(), P,
                                                 db.data(), diff, 1};
  struct Grads {
    std::vector<float> attr, rast, db, clip;
  };
  auto run = [&](int threads) {
    set_num_threads(threads);
    Grads g{std::vector<float>(N * C, 0.5f), std::vector<float>(4 * P, 0.0f), std::vector<float>(4 * P, 0.0f),
            std::vector<float>(4 * N, 0.25f)};
    raster::barycentric_interpolate_backward(ip, g_out.data(), g_da.data(), {g.attr.data(), g.rast.data(), g.db.data()});
    raster::barycentric_gbuffer_backward(gp, rast.data(), g_rast.data(), g_db.data(), g.clip.data());
    set_num_threads(0);
    return g;
  };
  const Grads one = run(1), two = run(2), eight = run(8);
  for (const Grads* g : {&two, &eight}) {
    CHECK(std::memcmp(g->attr.data(), one.attr.data(), one.attr.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(g->rast.data(), one.rast.data(), one.rast.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(g->db.data(), one.db.data(), one.db.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(g->clip.data(), one.clip.data(), one.clip.size() * sizeof(float)) == 0);
  }
  // Independently: dL/dA_k = sum over pixels of b_k g + (db_k/dx h_x + db_k/dy h_y) on channel 1, in pixel order.
  std::vector<double> want(N * C, 0.0);
  int covered = 0;
  for (std::int64_t q = 0; q < P; ++q) {
    if (s.tri_id[q] == 0) continue;
    ++covered;
    const std::int32_t* t = s.tris.data() + 3 * (s.tri_id[q] - 1);
    const double b[3] = {rast[4 * q], rast[4 * q + 1], 1.0 - rast[4 * q] - rast[4 * q + 1]};
    const double dx[3] = {db[4 * q], db[4 * q + 2], -double(db[4 * q]) - db[4 * q + 2]};
    const double dy[3] = {db[4 * q + 1], db[4 * q + 3], -double(db[4 * q + 1]) - db[4 * q + 3]};
    for (int k = 0; k < 3; ++k) {
      for (int c = 0; c < C; ++c) want[t[k] * C + c] += b[k] * g_out[q * C + c];
      want[t[k] * C + 1] += dx[k] * g_da[2 * q] + dy[k] * g_da[2 * q + 1];
    }
  }
  CHECK(covered > P / 2);
  for (std::int64_t i = 0; i < N * C; ++i)
    REQUIRE(std::abs((one.attr[i] - 0.5) - want[i]) <= 1e-5 * std::max(1.0, std::abs(want[i])));
}
