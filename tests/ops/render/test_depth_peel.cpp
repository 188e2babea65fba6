#include <catch2/catch.hpp>

#include <algorithm>
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
    return interpolate(attr, peeler.rasterize_next_layer(), tris);
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

// ---- batches (DepthPeeler::instanced, DepthPeeler::ranges) ----

namespace {

// One vertex list holding a tilted stack of 4 quads (quads 0 and 3 coincide:
// coplanar duplicates over their own vertices) and the two intersecting
// triangles, moved `shift` to the right. Triangles: the quads (0-7), the
// intersecting pair (8, 9) and quad 3 again (10, 11: duplicates over the same
// vertices, so in range mode a range starting at 6 holds coplanar ties).
Tensor hard_clip(double shift) {
  std::vector<double> v = quads_clip({0.4, -0.3, 0.0, 0.4}, 0.3).to_vector();
  for (double x : crossing_clip().to_vector()) v.push_back(x);
  for (std::size_t i = 0; i < v.size(); i += 4) v[i] += shift * v[i + 3];
  return Tensor::from_values(v, {22, 4}, DType::Float64);
}
Tensor hard_tris() {
  std::vector<std::int32_t> t;
  for (double x : quads_tris(4).to_vector()) t.push_back(static_cast<std::int32_t>(x));
  for (int k : {16, 17, 18, 19, 20, 21, 12, 13, 14, 12, 14, 15}) t.push_back(k);
  return Tensor::from_vector<std::int32_t>(t, {12, 3});
}

// Rows of B [N, C] tensors stacked into [B, N, C].
Tensor stack_images(const std::vector<Tensor>& images) {
  std::vector<double> v;
  for (const Tensor& t : images)
    for (double x : t.to_vector()) v.push_back(x);
  return Tensor::from_values(v, {static_cast<std::int64_t>(images.size()), images[0].size(0), images[0].size(1)},
                             DType::Float64);
}

// tri_id, uv and depth of each of `layers` layers.
using Layer = std::vector<std::vector<double>>;
std::vector<Layer> peel_values(DepthPeeler peeler, int layers) {
  std::vector<Layer> out;
  for (int k = 0; k < layers; ++k) {
    const GBuffer gb = peeler.rasterize_next_layer();
    out.push_back({gb.tri_id.to_vector(), gb.uv.to_vector(), gb.depth.to_vector()});
  }
  return out;
}

// The layers of images peeled alone, as one batch: image b's ids shifted by first[b].
std::vector<Layer> peel_each_alone(const std::vector<Tensor>& clips, const std::vector<Tensor>& tris,
                                   const std::vector<int>& first, int layers) {
  std::vector<Layer> batch(layers, Layer(3));
  for (std::size_t b = 0; b < clips.size(); ++b) {
    const std::vector<Layer> alone = peel_values(DepthPeeler(clips[b], tris[b], {kW, kH}), layers);
    for (int k = 0; k < layers; ++k) {
      for (double id : alone[k][0]) batch[k][0].push_back(id ? id + first[b] : 0.0);
      for (int i : {1, 2}) batch[k][i].insert(batch[k][i].end(), alone[k][i].begin(), alone[k][i].end());
    }
  }
  return batch;
}

// Layers 2 and 3 of a peel, uv and depth flattened into one vector.
Tensor later_layers(DepthPeeler peeler) {
  peeler.rasterize_next_layer();
  std::vector<Tensor> parts;
  for (int k = 0; k < 2; ++k) {
    const GBuffer gb = peeler.rasterize_next_layer();
    parts.push_back(reshape(gb.uv, {gb.uv.numel()}));
    parts.push_back(reshape(gb.depth, {gb.depth.numel()}));
  }
  return concat(parts, 0);
}

}  // namespace

TEST_CASE("batched depth peeling: every layer of an instanced and a range-mode peel equals peeling each image alone "
          "bit for bit, for 1, 2 and 8 threads",
          "[ops][depth_peel][batch][determinism]") {
  // Depth complexity 7 (3 coplanar quads, 2 more and both crossing
  // triangles): the last two layers are background.
  constexpr int kLayers = 9;
  const Tensor tris = hard_tris();
  SECTION("instanced") {
    const std::vector<Tensor> clips = {hard_clip(0.0), hard_clip(0.07), hard_clip(-0.13)};
    const Tensor batch_clip = stack_images(clips);
    const std::vector<Layer> expected = peel_each_alone(clips, {tris, tris, tris}, {0, 0, 0}, kLayers);
    auto covered = [](const Layer& l) { return std::count_if(l[0].begin(), l[0].end(), [](double id) { return id; }); };
    REQUIRE(covered(expected[6]) > 0);  // 7 layers deep somewhere, then background
    REQUIRE(covered(expected[7]) == 0);
    for (int threads : {1, 2, 8}) {
      INFO(threads << " threads");
      set_num_threads(threads);
      CHECK(peel_values(DepthPeeler::instanced(batch_clip, tris, {kW, kH}), kLayers) == expected);
    }
    set_num_threads(0);
  }
  SECTION("range mode (ids in the whole list, coplanar ties in a range starting at 6, an empty range)") {
    const Tensor clip = hard_clip(0.0);
    const std::vector<int> first = {0, 8, 6, 12}, count = {12, 2, 6, 0};
    const Tensor ranges = Tensor::from_vector<std::int32_t>({0, 12, 8, 2, 6, 6, 12, 0}, {4, 2});
    std::vector<Tensor> sub;
    for (std::size_t b = 0; b < first.size(); ++b) sub.push_back(slice(tris, 0, first[b], first[b] + count[b]));
    const std::vector<Layer> expected = peel_each_alone({clip, clip, clip, clip}, sub, first, kLayers);
    for (int threads : {1, 2, 8}) {
      INFO(threads << " threads");
      set_num_threads(threads);
      CHECK(peel_values(DepthPeeler::ranges(clip, tris, ranges, {kW, kH}), kLayers) == expected);
    }
    set_num_threads(0);
  }
}

TEST_CASE("batched depth peeling: uv and depth of layers 2 and 3 have gradients w.r.t. clip matching finite "
          "differences, with coplanar and intersecting faces",
          "[ops][depth_peel][batch][gradcheck]") {
  // The intersecting triangles and a quad drawn twice over the same vertices
  // (the coplanar tie holds bit for bit under any perturbation).
  auto scene = [](double shift, std::uint64_t seed) {
    std::vector<double> v = crossing_clip().to_vector();
    for (double x : quads_clip({0.1}).to_vector()) v.push_back(x);
    const std::vector<double> jitter = gr::testing::random_input({10, 4}, -0.002, 0.002, seed).to_vector();
    for (std::size_t i = 0; i < v.size(); ++i) v[i] += jitter[i] + (i % 4 == 0 ? shift * v[i + 3] : 0.0);
    return Tensor::from_values(v, {10, 4}, DType::Float64);
  };
  const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5, 6, 7, 8, 6, 8, 9, 6, 7, 8, 6, 8, 9}, {6, 3});
  SECTION("instanced") {
    Tensor clip = stack_images({scene(0.0, 21), scene(0.1, 22)}).set_requires_grad();
    require_gradcheck("batched peel layers 2-3 (instanced)",
                      [&](const Inputs& in) { return later_layers(DepthPeeler::instanced(in[0], tris, {kW, kH})); },
                      {clip});
  }
  SECTION("range mode") {
    Tensor clip = scene(0.0, 23).set_requires_grad();
    const Tensor ranges = Tensor::from_vector<std::int32_t>({0, 2, 2, 4, 0, 6}, {3, 2});
    require_gradcheck("batched peel layers 2-3 (ranges)",
                      [&](const Inputs& in) {
                        return later_layers(DepthPeeler::ranges(in[0], tris, ranges, {kW, kH}));
                      },
                      {clip});
  }
}

TEST_CASE("batched depth peeling: bad batches are rejected when the peeler is built, naming the argument",
          "[ops][depth_peel][batch][errors]") {
  const Tensor clip = hard_clip(0.0), tris = hard_tris();
  CHECK_THROWS_WITH(DepthPeeler::instanced(clip, tris, {kW, kH}),
                    Catch::Contains("DepthPeeler::instanced") && Catch::Contains("'clip' must have shape [B, N, 4]"));
  const Tensor outside = Tensor::from_vector<std::int32_t>({0, 4, 8, 5}, {2, 2});
  CHECK_THROWS_AS(DepthPeeler::ranges(clip, tris, outside, {kW, kH}), IndexError);
  CHECK_THROWS_WITH(DepthPeeler::ranges(clip, tris, outside, {kW, kH}),
                    Catch::Contains("DepthPeeler::ranges") &&
                        Catch::Contains("ranges[1] = (8, 5) is outside the 12 triangles"));
  CHECK_THROWS_WITH(DepthPeeler::ranges(clip, tris, Tensor::from_vector<std::int32_t>({0, 4, 8}, {1, 3}), {kW, kH}),
                    Catch::Contains("'ranges' must have shape [B, 2]"));
  CHECK_THROWS_WITH(DepthPeeler::ranges(clip, tris, Tensor::zeros({2, 2}, DType::Float64), {kW, kH}),
                    Catch::Contains("'ranges'"));
}
