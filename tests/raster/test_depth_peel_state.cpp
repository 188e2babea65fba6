// Depth peeling written once (raster/depth_peel_state.h): a stack of quads
// comes back one quad per layer nearest first, then background; each image
// of a batch peels on its own key; the layers are bit-identical for 1, 2 and
// 8 threads; a layer of another size is refused.
#include <catch2/catch.hpp>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/depth_peel_state.h"
#include "raster/image_batch.h"

using namespace gr;
using namespace gr::raster;

namespace {

constexpr int W = 8, H = 6;

// Full-screen quads (two triangles each) at the given NDC depths, in this
// order, shifted by dx in x (so image b of a batch can differ).
struct Stack {
  std::vector<double> clip;
  std::vector<std::int32_t> tris;
};
Stack quad_stack(const std::vector<double>& depths, double dx = 0.0) {
  Stack s;
  for (std::size_t q = 0; q < depths.size(); ++q) {
    const std::int32_t v = static_cast<std::int32_t>(4 * q);
    for (auto [x, y] : {std::pair{-1.5, -1.5}, {1.5, -1.5}, {1.5, 1.5}, {-1.5, 1.5}})
      for (double c : {x + dx, y, depths[q], 1.0}) s.clip.push_back(c);
    for (std::int32_t i : {v, v + 1, v + 2, v, v + 2, v + 3}) s.tris.push_back(i);
  }
  return s;
}

struct Layer {
  std::vector<std::int32_t> id;
  std::vector<double> uv, depth;
  bool operator==(const Layer& o) const { return id == o.id && uv == o.uv && depth == o.depth; }
};

// `layers` layers of a batch of stacks (image b: stacks[b]) through one DepthPeelState.
std::vector<std::vector<Layer>> peel(const std::vector<Stack>& stacks, int layers) {
  DepthPeelState state;
  std::vector<std::vector<Layer>> out(static_cast<std::size_t>(layers));
  for (int l = 0; l < layers; ++l) {
    out[l].resize(stacks.size(), {std::vector<std::int32_t>(W * H), std::vector<double>(2 * W * H),
                                  std::vector<double>(W * H)});
    state.begin_layer(static_cast<std::int64_t>(stacks.size()), W, H);
    for_each_image(static_cast<std::int64_t>(stacks.size()), [&](std::int64_t b) {
      const Stack& s = stacks[b];
      RasterParams<double> p{s.clip.data(), static_cast<std::int64_t>(s.clip.size() / 4), s.tris.data(),
                             static_cast<std::int64_t>(s.tris.size() / 3), RasterSettings{W, H}};
      Layer& L = out[l][b];
      state.rasterize_image(p, b, L.id.data(), L.uv.data(), L.depth.data());
    });
    state.end_layer();
    CHECK(state.layers() == l + 1);
  }
  return out;
}

// The quad (0-based, in the stack's order) each pixel of a layer shows; -1 = background.
std::vector<int> quads(const Layer& layer) {
  std::vector<int> q;
  for (std::int32_t id : layer.id) q.push_back(id == 0 ? -1 : (id - 1) / 2);
  return q;
}

}  // namespace

TEST_CASE("depth peel state: a stack of quads comes back one quad per layer, nearest first, then background",
          "[raster][depth_peel_state]") {
  // Stored far, near, middle: the layers follow depth, not the triangle order.
  const std::vector<std::vector<Layer>> layers = peel({quad_stack({0.8, -0.4, 0.3})}, 5);
  for (const auto& [layer, quad] : {std::pair{0, 1}, {1, 2}, {2, 0}, {3, -1}, {4, -1}})
    CHECK(quads(layers[layer][0]) == std::vector<int>(W * H, quad));
  for (double d : layers[0][0].depth) CHECK(d == Approx(-0.4).margin(1e-12));
  CHECK(layers[3][0].depth == std::vector<double>(W * H, kBackgroundDepth));
}

TEST_CASE("depth peel state: each image of a batch peels behind its own previous layer",
          "[raster][depth_peel_state]") {
  const std::vector<Stack> stacks = {quad_stack({0.1, 0.6}), quad_stack({0.5, -0.2, 0.0}, 0.25), quad_stack({0.7})};
  const std::vector<std::vector<Layer>> batch = peel(stacks, 4);
  for (std::size_t b = 0; b < stacks.size(); ++b) {
    const std::vector<std::vector<Layer>> alone = peel({stacks[b]}, 4);
    for (int l = 0; l < 4; ++l) CHECK(batch[l][b] == alone[l][0]);
  }
  CHECK(quads(batch[1][1]) == std::vector<int>(W * H, 2));
  CHECK(quads(batch[1][2]) == std::vector<int>(W * H, -1));
}

TEST_CASE("depth peel state: layers are bit-identical for 1, 2 and 8 threads", "[raster][depth_peel_state][determinism]") {
  const std::vector<Stack> stacks = {quad_stack({0.1, 0.6, 0.6}), quad_stack({0.5, -0.2, 0.0}, 0.3)};
  set_num_threads(1);
  const auto one = peel(stacks, 4);
  for (int threads : {2, 8}) {
    set_num_threads(threads);
    CHECK(peel(stacks, 4) == one);
  }
  set_num_threads(0);
}

TEST_CASE("depth peel state: the floor is absent on the first layer and the previous key after",
          "[raster][depth_peel_state]") {
  DepthPeelState state;
  state.begin_layer(2, W, H);
  CHECK(state.floor_id(1) == nullptr);
  CHECK(state.floor_z(1) == nullptr);
  std::vector<std::int32_t> ids(W * H, 7);
  state.keep_ids(1, ids.data());
  state.key_z(1)[3] = 0.25;
  state.end_layer();
  state.begin_layer(2, W, H);
  REQUIRE(state.floor_id(1) != nullptr);
  CHECK(std::vector<std::int32_t>(state.floor_id(1), state.floor_id(1) + W * H) == ids);
  CHECK(state.floor_z(1)[3] == 0.25);
}

TEST_CASE("depth peel state: a layer with other images or another size is a ValueError",
          "[raster][depth_peel_state][errors]") {
  DepthPeelState state;
  state.begin_layer(2, W, H);
  state.end_layer();
  CHECK_NOTHROW(state.begin_layer(2, W, H));
  state.end_layer();
  try {
    state.begin_layer(3, W, H);
    FAIL("no exception");
  } catch (const ValueError& e) {
    CHECK(std::string(e.what()) == "DepthPeeler: layer 3 has 3 images of 8 x 6 pixels, but the layers before it had 96 "
                                   "pixels in all");
  }
  CHECK_THROWS_AS(state.begin_layer(2, W + 1, H), ValueError);
}
