// Fragment mode (ops/render/fragments.h): the same values and gradients as the image
// form on covered pixels (also on near-clipped triangles), gradients through
// every step, empty sets, errors.
#include <catch2/catch.hpp>

#include "ops/clip_scenes.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {

struct MeshScene {
  Tensor positions, colours, normals, triangles, mvp;
};

// A run returns the image followed by every gradient. Fragment mode at 1 and
// 2 threads must equal image mode (2 threads) bit for bit.
template <class Run>
void require_fragment_mode_equals_image_mode(Run run) {
  const auto image_mode = run(false, 2);
  const auto frag_1 = run(true, 1);
  const auto frag_2 = run(true, 2);
  REQUIRE(image_mode.size() == frag_1.size());
  std::int64_t differing = 0;
  for (std::size_t i = 0; i < image_mode.size(); ++i) differing += image_mode[i] != frag_1[i];
  CHECK(differing == 0);
  CHECK(frag_1 == frag_2);
}

// Triangle 0: vertex 1 behind the camera, vertex 2 at w = w2 (clipped form);
// triangle 1: in front of it, fully in front of the near plane.
Tensor clipped_scene_clip(double w2, DType dtype) {
  return Tensor::from_values({-0.6, -0.5, -0.8, 1.0, 0.7, -0.4, 1.3, 1.5, 0.3, -0.8, -0.6 - w2, w2,  //
                              -0.5, 0.2, 0.1, 1.1, 0.3, 0.4, 0.2, 1.2, -0.2, 0.7, 0.1, 0.9},
                             {6, 4}, dtype);
}

// A torus seen at an angle: partial coverage, silhouettes and occlusion.
MeshScene torus_scene(DType dtype) {
  raster::Mesh mesh = raster::make_torus(24, 12, 1.0f, 0.35f);
  MeshScene s;
  s.positions = cast(mesh.positions, dtype).set_requires_grad();
  s.normals = cast(mesh.normals, dtype);
  s.colours = Tensor::uniform({mesh.num_vertices(), 3}, 0.1, 0.9, 5, dtype).set_requires_grad();
  s.triangles = mesh.triangles;
  Tensor eye = Tensor::from_values({0.2, 1.5, 2.4}, {3}, dtype);
  Tensor up = Tensor::from_values({0, 1, 0}, {3}, dtype);
  s.mvp = matmul(cast(perspective(0.8, 1.25, 0.1, 10.0), dtype), look_at(eye, Tensor::zeros({3}, dtype), up));
  return s;
}

// Lambert-shaded image, composited over `background`, in image or fragment mode.
Tensor render(const MeshScene& s, bool fragment_mode, const Tensor& background, int w, int h) {
  Tensor clip = transform_points(s.positions, s.mvp);
  GBuffer gb = rasterize(clip, s.triangles, {w, h});
  Tensor light = normalize(Tensor::from_values({0.5, 0.8, 1.0}, {3}, s.positions.dtype()));
  auto shade = [&](const Tensor& albedo, const Tensor& normal) {
    return albedo * (0.3 + 0.7 * maximum(dot(normalize(normal), light), 0.0));
  };
  if (fragment_mode) {
    Fragments fr = fragments(gb);
    return to_image(shade(interpolate(s.colours, fr, s.triangles), interpolate(s.normals, fr, s.triangles)),
                    fr, background);
  }
  InterpolateOptions bg;
  bg.background = background;
  Tensor shaded = shade(interpolate(s.colours, gb, s.triangles), interpolate(s.normals, gb, s.triangles));
  Tensor coverage = reshape(greater(cast(gb.tri_id, s.positions.dtype()), Tensor::scalar(0.0, s.positions.dtype())), {h, w, 1});
  return shaded * coverage + background * (1.0 - coverage);
}

}  // namespace

TEST_CASE("fragments: compaction lists the covered pixels in ascending order with their ids and barycentrics",
          "[ops][fragments]") {
  Tensor clip = gr::testing::two_triangles_clip();
  GBuffer gb = rasterize(clip, gr::testing::two_triangles(), {24, 20});
  Fragments fr = fragments(gb);
  CHECK(fr.width == 24);
  CHECK(fr.height == 20);
  std::int64_t f = 0;
  for (std::int64_t p = 0; p < 24 * 20; ++p) {
    const std::int32_t id = gb.tri_id.data<std::int32_t>()[p];
    if (id == 0) continue;
    REQUIRE(f < fr.count());
    CHECK(fr.pixel_index.data<std::int32_t>()[f] == p);
    CHECK(fr.tri_id.data<std::int32_t>()[f] == id);
    CHECK(fr.uv.at({f, 0}) == gb.uv.data<double>()[2 * p]);
    CHECK(fr.uv.at({f, 1}) == gb.uv.data<double>()[2 * p + 1]);
    ++f;
  }
  CHECK(f == fr.count());
  CHECK(f > 50);
}

TEST_CASE("fragments: fragment mode equals image mode bit for bit, values and gradients, for 1 and 2 threads",
          "[ops][fragments][determinism]") {
  const int w = 96, h = 72;
  for (DType dtype : {DType::Float32, DType::Float64}) {
    INFO("dtype " << dtype_name(dtype));
    MeshScene s = torus_scene(dtype);
    Tensor background = Tensor::from_values({0.1, 0.2, 0.3}, {3}, dtype);
    Tensor weights = Tensor::uniform({h, w, 3}, -1, 1, 9, dtype);
    auto run = [&](bool fragment_mode, int threads) {
      set_num_threads(threads);
      s.positions.zero_grad();
      s.colours.zero_grad();
      Tensor image = render(s, fragment_mode, background, w, h);
      backward(sum(image * weights));
      set_num_threads(0);
      std::vector<double> all = image.to_vector();
      for (double x : s.positions.grad().to_vector()) all.push_back(x);
      for (double x : s.colours.grad().to_vector()) all.push_back(x);
      return all;
    };
    {
      NoGradGuard no_grad;
      const GBuffer gb = rasterize(transform_points(s.positions, s.mvp), s.triangles, {w, h});
      const std::int64_t covered = fragments(gb).count();
      REQUIRE(covered > w * h / 5);  // partial coverage: both kinds of pixels are tested
      REQUIRE(covered < w * h * 4 / 5);
    }
    require_fragment_mode_equals_image_mode(run);
  }
}

TEST_CASE("fragments: interpolate on fragments matches finite differences through rasterize",
          "[ops][fragments][gradcheck]") {
  Tensor tris = gr::testing::two_triangles();
  Tensor attr = random_input({6, 3}, -1, 1, 61);
  Tensor clip = gr::testing::two_triangles_clip().set_requires_grad();
  // Attributes and clip positions, through fragments' uv gather and rasterize's adjoint.
  require_gradcheck("interpolate fragments",
                    [&](const Inputs& in) {
                      GBuffer gb = rasterize(in[1], tris, {24, 20});
                      return interpolate(in[0], fragments(gb), tris);
                    },
                    {attr, clip});
}

TEST_CASE("fragments: to_image and gather_fragments match finite differences", "[ops][fragments][gradcheck]") {
  Tensor clip = gr::testing::two_triangles_clip();
  GBuffer gb = rasterize(clip, gr::testing::two_triangles(), {24, 20});
  Fragments fr = fragments(gb);
  const std::int64_t n = fr.count();
  Tensor values = random_input({n, 2}, -1, 1, 71);
  Tensor bg = random_input({2}, -1, 1, 72);
  Tensor bg_image = random_input({20, 24, 2}, -1, 1, 73);
  require_gradcheck("to_image (values, background [C])",
                    [&](const Inputs& in) { return to_image(in[0], fr, in[1]); }, {values, bg});
  require_gradcheck("to_image (values, background image)",
                    [&](const Inputs& in) { return to_image(in[0], fr, in[1]); }, {values, bg_image});
  require_gradcheck("to_image (values, no background)", [&](const Inputs& in) { return to_image(in[0], fr); },
                    {values});
  Tensor image = random_input({20, 24, 3}, -1, 1, 74);
  require_gradcheck("gather_fragments", [&](const Inputs& in) { return gather_fragments(in[0], fr); }, {image});
}

TEST_CASE("fragments: to_image puts the background on uncovered pixels and the values on covered ones",
          "[ops][fragments]") {
  Tensor clip = gr::testing::two_triangles_clip();
  GBuffer gb = rasterize(clip, gr::testing::two_triangles(), {24, 20});
  Fragments fr = fragments(gb);
  Tensor values = Tensor::full({fr.count(), 1}, 5.0, DType::Float64);
  Tensor out = to_image(values, fr, Tensor::from_values({-2}, {1}, DType::Float64));
  for (std::int64_t y = 0; y < 20; ++y)
    for (std::int64_t x = 0; x < 24; ++x) CHECK(out.at({y, x, 0}) == (gb.tri_id.at({y, x}) != 0 ? 5.0 : -2.0));
  Tensor zeros_bg = to_image(values, fr);
  CHECK(zeros_bg.at({0, 0, 0}) == 0.0);  // the corner is uncovered in this scene
  CHECK(gb.tri_id.at({0, 0}) == 0);
}

TEST_CASE("fragments: an empty fragment set gives the background and zero gradients", "[ops][fragments][empty]") {
  // Both triangles far off to the right: nothing covered.
  Tensor clip = gr::testing::two_triangles_clip();
  Tensor shift = Tensor::from_values({5, 0, 0, 0}, {4}, DType::Float64);
  Tensor moved = (clip + shift).detach().set_requires_grad();
  Tensor tris = gr::testing::two_triangles();
  Tensor attr = random_input({6, 2}, -1, 1, 81);
  Tensor bg = random_input({2}, -1, 1, 82);
  GBuffer gb = rasterize(moved, tris, {16, 12});
  Fragments fr = fragments(gb);
  REQUIRE(fr.count() == 0);
  CHECK(fr.uv.shape() == Shape{0, 2});
  Tensor values = interpolate(attr, fr, tris);
  CHECK(values.shape() == Shape{0, 2});
  Tensor image = to_image(values * 2.0, fr, bg);
  CHECK(image.shape() == Shape{12, 16, 2});
  CHECK(image.at({3, 4, 1}) == bg.at({1}));
  backward(sum(image));
  for (double g : attr.grad().to_vector()) CHECK(g == 0.0);
  for (double g : moved.grad().to_vector()) CHECK(g == 0.0);
  CHECK(bg.grad().at({0}) == 16 * 12);
}

TEST_CASE("fragments: bad inputs throw errors naming the argument", "[ops][fragments][errors]") {
  Tensor clip = gr::testing::two_triangles_clip();
  Tensor tris = gr::testing::two_triangles();
  GBuffer gb = rasterize(clip, tris, {24, 20});
  Fragments fr = fragments(gb);
  const std::int64_t n = fr.count();
  CHECK_THROWS_WITH(fragments(GBuffer{}), Catch::Contains("gbuffer"));
  CHECK_THROWS_WITH(to_image(Tensor::ones({n + 1, 3}, DType::Float64), fr), Catch::Contains("values"));
  CHECK_THROWS_WITH(to_image(Tensor::ones({n, 3}, DType::Float64), fr, Tensor::ones({2}, DType::Float64)),
                    Catch::Contains("background"));
  CHECK_THROWS_AS(to_image(Tensor::ones({n, 3}, DType::Float64), fr, Tensor::ones({3})), DTypeError);
  CHECK_THROWS_AS(to_image(Tensor::ones({n, 3}, DType::Int32), fr), DTypeError);
  CHECK_THROWS_WITH(gather_fragments(Tensor::ones({20, 23, 3}), fr), Catch::Contains("image"));
  CHECK_THROWS_WITH(to_image(Tensor::ones({n, 3}), Fragments{}), Catch::Contains("fragments"));
  InterpolateOptions with_bg;
  with_bg.background = Tensor::ones({3}, DType::Float64);
  CHECK_THROWS_WITH(interpolate(Tensor::ones({6, 3}, DType::Float64), fr, tris, with_bg),
                    Catch::Contains("background"));
  CHECK_THROWS_WITH(interpolate(Tensor::ones({6, 3}), fr, tris), Catch::Contains("fragments.uv"));
  // Hand-edited fragments: unsorted pixel indices, a background tri_id, a uv of the wrong size.
  Fragments unsorted = fr;
  unsorted.pixel_index = fr.pixel_index.copy();
  std::swap(unsorted.pixel_index.data<std::int32_t>()[0], unsorted.pixel_index.data<std::int32_t>()[1]);
  CHECK_THROWS_AS(to_image(Tensor::ones({n, 1}, DType::Float64), unsorted), IndexError);
  Fragments bad_id = fr;
  bad_id.tri_id = fr.tri_id.copy();
  bad_id.tri_id.data<std::int32_t>()[0] = 0;
  CHECK_THROWS_AS(interpolate(Tensor::ones({6, 3}, DType::Float64), bad_id, tris), IndexError);
  Fragments bad_uv = fr;
  bad_uv.uv = Tensor::zeros({n, 3}, DType::Float64);
  CHECK_THROWS_WITH(interpolate(Tensor::ones({6, 3}, DType::Float64), bad_uv, tris), Catch::Contains("uv"));
}

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
          image = to_image(interpolate(attr, fr, tris), fr);
        } else {
          image = interpolate(attr, gb, tris);
        }
        backward(sum(image * weights));
        set_num_threads(0);
        std::vector<double> all = image.to_vector();
        for (double x : clip.grad().to_vector()) all.push_back(x);
        for (double x : attr.grad().to_vector()) all.push_back(x);
        return all;
      };
      require_fragment_mode_equals_image_mode(run);
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
  require_gradcheck("interpolate fragments clipped, w = 0 (attributes, uv)",
                    [&](const Inputs& in) {
                      Fragments f = fr;
                      f.uv = in[1];
                      return interpolate(in[0], f, tris);
                    },
                    {attr, fr.uv});
  GradcheckOptions small;
  small.eps = 1e-7;  // the coverage must not change
  small.rtol = 1e-5;
  require_gradcheck("interpolate fragments clipped, w = 0 (clip through rasterize)",
                    [&](const Inputs& in) {
                      const GBuffer g = rasterize(in[1], tris, {20, 16});
                      return to_image(interpolate(in[0], fragments(g), tris), fragments(g));
                    },
                    {attr, clip}, small);
}
