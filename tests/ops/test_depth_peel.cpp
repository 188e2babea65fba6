#include <catch2/catch.hpp>

#include <set>
#include <vector>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

constexpr int kW = 20, kH = 16;

// Quads (two triangles each) over most of the screen at the given depths,
// corners offset by `tilt` * z so non-coplanar quads also differ in x, y.
Tensor quads_clip(const std::vector<double>& z, double tilt = 0.0) {
  std::vector<double> c;
  for (double d : z) {
    const double s = 0.8 + tilt * d;
    for (auto [x, y] : {std::pair{-s, -s}, {s, -s}, {s, s}, {-s, s}}) c.insert(c.end(), {x, y, d, 1.0});
  }
  return Tensor::from_vector<double>(c, {static_cast<std::int64_t>(z.size()) * 4, 4});
}

Tensor quads_tris(int n) {
  std::vector<std::int32_t> t;
  for (int k = 0; k < n; ++k) t.insert(t.end(), {4 * k, 4 * k + 1, 4 * k + 2, 4 * k, 4 * k + 2, 4 * k + 3});
  return Tensor::from_vector<std::int32_t>(t, {2 * static_cast<std::int64_t>(n), 3});
}

// Two triangles crossing each other: the layer boundary is their intersection line.
Tensor crossing_clip() {
  return Tensor::from_vector<double>({-0.9, -0.8, -0.5, 1, 0.9, -0.7, 0.5, 1, 0.0, 0.9, 0.0, 1,  //
                                      -0.8, 0.7, 0.5, 1, 0.9, 0.8, -0.5, 1, 0.1, -0.9, 0.0, 1},
                                     {6, 4});
}
Tensor crossing_tris() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3}); }

// Peels until a layer is empty (at most `max_layers`) and requires that each
// pixel sees every triangle covering it exactly once, in (depth, id) order.
void require_each_triangle_once(const Tensor& clip, const Tensor& tris, int max_layers) {
  const std::int64_t m = tris.size(0);
  std::vector<std::set<int>> covering(kW * kH);  // triangles covering each pixel, rasterized alone
  for (std::int64_t t = 0; t < m; ++t) {
    Tensor one = Tensor::from_vector<std::int32_t>(
        {int(tris.at({t, 0})), int(tris.at({t, 1})), int(tris.at({t, 2}))}, {1, 3});
    GBuffer gb = rasterize(clip, one, {kW, kH});
    for (int p = 0; p < kW * kH; ++p)
      if (gb.tri_id.to_vector()[p] != 0) covering[p].insert(int(t) + 1);
  }
  DepthPeeler peeler(clip, tris, {kW, kH});
  std::vector<std::vector<int>> seen(kW * kH);
  std::vector<double> last_depth(kW * kH, -2.0);
  for (int layer = 0; layer < max_layers; ++layer) {
    GBuffer gb = peeler.rasterize_next_layer();
    const std::vector<double> id = gb.tri_id.to_vector(), depth = gb.depth.to_vector();
    for (int p = 0; p < kW * kH; ++p) {
      if (id[p] == 0) continue;
      CHECK(depth[p] >= last_depth[p]);  // never nearer than the layer in front
      last_depth[p] = depth[p];
      seen[p].push_back(int(id[p]));
    }
  }
  for (int p = 0; p < kW * kH; ++p) {
    INFO("pixel " << p);
    CHECK(std::set<int>(seen[p].begin(), seen[p].end()) == covering[p]);
    CHECK(seen[p].size() == covering[p].size());
  }
}

}  // namespace

TEST_CASE("depth peeling: a stack of parallel quads comes back one quad per layer, nearest first",
          "[ops][depth_peel]") {
  const std::vector<double> z = {0.3, -0.5, 0.1};
  DepthPeeler peeler(quads_clip(z), quads_tris(3), {kW, kH});
  for (int expected_quad : {1, 2, 0}) {
    GBuffer gb = peeler.rasterize_next_layer();
    const std::vector<double> id = gb.tri_id.to_vector();
    int covered = 0;
    for (double v : id) {
      if (v == 0) continue;
      ++covered;
      CHECK((int(v) - 1) / 2 == expected_quad);
    }
    CHECK(covered > kW * kH / 2);
  }
}

TEST_CASE("depth peeling: layers past the last one are background everywhere", "[ops][depth_peel]") {
  DepthPeeler peeler(quads_clip({0.2, -0.2}), quads_tris(2), {kW, kH});
  for (int k = 0; k < 2; ++k) peeler.rasterize_next_layer();
  for (int k = 0; k < 2; ++k) {
    GBuffer gb = peeler.rasterize_next_layer();
    for (double v : gb.tri_id.to_vector()) CHECK(v == 0);
    for (double v : gb.uv.to_vector()) CHECK(v == 0);
    for (double v : gb.depth.to_vector()) CHECK(v == raster::kBackgroundDepth);
  }
}

TEST_CASE("depth peeling: coplanar duplicates and intersecting faces each appear exactly once across layers",
          "[ops][depth_peel]") {
  SECTION("coplanar duplicates") { require_each_triangle_once(quads_clip({0.1, 0.1, 0.1}), quads_tris(3), 8); }
  SECTION("intersecting faces") { require_each_triangle_once(crossing_clip(), crossing_tris(), 4); }
  SECTION("tilted stack") { require_each_triangle_once(quads_clip({0.4, -0.3, 0.0, 0.4}, 0.3), quads_tris(4), 10); }
}

TEST_CASE("depth peeling: the first layer equals rasterize bit for bit", "[ops][depth_peel]") {
  Tensor clip = quads_clip({0.4, -0.3, 0.0, 0.4}, 0.3), tris = quads_tris(4);
  for (bool f2b : {false, true}) {
    RasterizeOptions o{kW, kH};
    o.front_to_back = f2b;
    GBuffer a = rasterize(clip, tris, o), b = DepthPeeler(clip, tris, o).rasterize_next_layer();
    CHECK(a.tri_id.to_vector() == b.tri_id.to_vector());
    CHECK(a.uv.to_vector() == b.uv.to_vector());
    CHECK(a.depth.to_vector() == b.depth.to_vector());
  }
}

TEST_CASE("depth peeling: layers are bit-identical for 1, 2 and 8 threads", "[ops][depth_peel][determinism]") {
  Tensor clip = quads_clip({0.4, -0.3, 0.0, 0.4, 0.1}, 0.3), tris = quads_tris(5);
  std::vector<std::vector<double>> runs;
  for (int n : {1, 2, 8}) {
    set_num_threads(n);
    DepthPeeler peeler(clip, tris, {kW, kH});
    std::vector<double> all;
    for (int k = 0; k < 6; ++k) {
      GBuffer gb = peeler.rasterize_next_layer();
      for (const Tensor* t : {&gb.tri_id, &gb.uv, &gb.depth}) {
        const std::vector<double> v = t->to_vector();
        all.insert(all.end(), v.begin(), v.end());
      }
    }
    runs.push_back(all);
  }
  set_num_threads(0);
  CHECK(runs[0] == runs[1]);
  CHECK(runs[0] == runs[2]);
}

TEST_CASE("depth peeling: interpolate on layer 2 has gradients matching finite differences",
          "[ops][depth_peel][gradcheck]") {
  // Layer 2 through interpolate, w.r.t. clip and attributes.
  auto layer2 = [](const Tensor& attr, const Tensor& clip, const Tensor& tris) {
    DepthPeeler peeler(clip, tris, {kW, kH});
    peeler.rasterize_next_layer();
    return interpolate(attr, clip, peeler.rasterize_next_layer(), tris);
  };
  SECTION("random tilted stack") {
    Tensor clip = (quads_clip({0.4, -0.3, 0.0}, 0.3) +
                   gr::testing::random_input({12, 4}, -0.02, 0.02, 7)).detach().set_requires_grad();
    Tensor attr = gr::testing::random_input({12, 3}, -1, 1, 8).set_requires_grad();
    Tensor tris = quads_tris(3);
    require_gradcheck("peel layer 2 (random)", [&](const Inputs& in) { return layer2(in[0], in[1], tris); },
                      {attr, clip}, GradcheckOptions{1e-4});
  }
  SECTION("intersecting faces") {
    Tensor clip = crossing_clip().set_requires_grad();
    Tensor attr = gr::testing::random_input({6, 2}, -1, 1, 9).set_requires_grad();
    Tensor tris = crossing_tris();
    require_gradcheck("peel layer 2 (intersecting)", [&](const Inputs& in) { return layer2(in[0], in[1], tris); },
                      {attr, clip}, GradcheckOptions{1e-4});
  }
  SECTION("coplanar duplicates (one quad drawn twice over the same vertices: the tie holds bit for bit)") {
    Tensor clip = (quads_clip({0.1}) + gr::testing::random_input({4, 4}, -0.002, 0.002, 10)).detach().set_requires_grad();
    Tensor attr = gr::testing::random_input({4, 3}, -1, 1, 11).set_requires_grad();
    Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 0, 2, 3, 0, 1, 2, 0, 2, 3}, {4, 3});
    require_gradcheck("peel layer 2 (coplanar)", [&](const Inputs& in) { return layer2(in[0], in[1], tris); },
                      {attr, clip}, GradcheckOptions{1e-4});
  }
}

TEST_CASE("depth peeling: bad inputs are rejected when the peeler is built, naming the argument",
          "[ops][depth_peel][errors]") {
  Tensor clip = quads_clip({0.1}), tris = quads_tris(1);
  CHECK_THROWS_AS(DepthPeeler(clip, tris, {0, 8}), ValueError);
  CHECK_THROWS_WITH(DepthPeeler(Tensor::ones({4, 3}, DType::Float64), tris, {8, 8}), Catch::Contains("DepthPeeler"));
  CHECK_THROWS_AS(DepthPeeler(clip, Tensor::from_vector<std::int32_t>({0, 1, 9}, {1, 3}), {8, 8}), IndexError);
  Tensor bad = quads_clip({0.1});
  bad.data<double>()[2] = std::nan("");
  CHECK_THROWS_WITH(DepthPeeler(bad, tris, {8, 8}), Catch::Contains("clip"));
}
