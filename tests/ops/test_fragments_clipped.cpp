// Fragment form on a near-clipped triangle with a vertex at w = 0.
#include <catch2/catch.hpp>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {
// Triangle 0: vertex 1 behind the camera, vertex 2 at w = w2 (clipped form);
// triangle 1: in front of it, fully in front of the near plane.
Tensor clipped_scene_clip(double w2, DType dtype) {
  return Tensor::from_values({-0.6, -0.5, -0.8, 1.0, 0.7, -0.4, 1.3, 1.5, 0.3, -0.8, -0.6 - w2, w2,  //
                              -0.5, 0.2, 0.1, 1.1, 0.3, 0.4, 0.2, 1.2, -0.2, 0.7, 0.1, 0.9},
                             {6, 4}, dtype);
}
}  // namespace

TEST_CASE("fragment mode equals image mode bit for bit on a clipped triangle with a vertex at w = 0",
          "[ops][fragments][near]") {
  const int w = 40, h = 32;
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  for (DType dtype : {DType::Float32, DType::Float64})
    for (double w2 : {0.0, -0.6, 1e-7}) {
      INFO("dtype " << dtype_name(dtype) << " w2 " << w2);
      Tensor clip = clipped_scene_clip(w2, dtype).set_requires_grad();
      Tensor attr = cast(random_input({6, 3}, -1, 1, 7), dtype).detach().set_requires_grad();
      Tensor weights = Tensor::uniform({h, w, 3}, -1, 1, 9, dtype);
      auto run = [&](bool fragment_mode, int threads) {
        set_num_threads(threads);
        clip.zero_grad();
        attr.zero_grad();
        GBuffer gb = rasterize(clip, tris, {w, h});
        Tensor image;
        if (fragment_mode) {
          Fragments fr = fragments(gb);
          image = to_image(interpolate(attr, clip, fr, tris), fr);
        } else {
          image = interpolate(attr, clip, gb, tris);
        }
        backward(sum(image * weights));
        set_num_threads(0);
        std::vector<double> all = image.to_vector();
        for (double x : clip.grad().to_vector()) all.push_back(x);
        for (double x : attr.grad().to_vector()) all.push_back(x);
        return all;
      };
      const auto image_mode = run(false, 2);
      const auto frag_1 = run(true, 1);
      const auto frag_2 = run(true, 2);
      REQUIRE(image_mode.size() == frag_1.size());
      std::int64_t differing = 0;
      for (std::size_t i = 0; i < image_mode.size(); ++i) differing += image_mode[i] != frag_1[i];
      CHECK(differing == 0);
      CHECK(frag_1 == frag_2);
    }
}

TEST_CASE("fragment-form gradients of a clipped triangle with a vertex at w = 0 match finite differences",
          "[ops][fragments][near][gradcheck]") {
  Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 4, 5}, {2, 3});
  Tensor attr = random_input({6, 3}, -1, 1, 43);
  Tensor clip = clipped_scene_clip(0.0, DType::Float64).set_requires_grad();
  GBuffer gb = rasterize(clip.detach(), tris, {20, 16});
  Fragments fr = fragments(gb);
  REQUIRE(fr.count() > 20);
  std::int64_t clipped = 0;
  for (double id : fr.tri_id.to_vector()) clipped += id == 1;
  INFO("fragments of the clipped triangle: " << clipped);
  REQUIRE(clipped > 10);
  // Some of them not at item index = pixel index (so pixel_index matters).
  REQUIRE(fr.pixel_index.to_vector().back() > fr.count());
  fr.uv = fr.uv.detach().copy().set_requires_grad();
  require_gradcheck("interpolate fragments clipped, w = 0",
                    [&](const Inputs& in) {
                      Fragments f = fr;
                      f.uv = in[2];
                      return interpolate(in[0], in[1], f, tris);
                    },
                    {attr, clip, fr.uv});
}
