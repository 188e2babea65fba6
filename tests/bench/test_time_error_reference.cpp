// time_error's exact reference (bench/time_error_exact.h): finite differences
// of the exact box-filtered loss on the torus converge at the chosen step,
// where those of a supersampled render do not, and the antialiased analytic
// gradient lands near them. The other scenes show what they are built to
// show (both objects, hidden parts, culling) and are smooth at that step too.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "autodiff/tape.h"
#include "autodiff/base/error.h"
#include "bench/time_error_exact.h"
#include "bench/time_error_regions.h"
#include "ops/ops.h"

namespace gr {
namespace {

using namespace bench;

// h vs 2h spread of the 2nd-order differences (relative L2).
double spread(const ReferenceDerivatives& d) { return relative_l2(d.position_h, d.position_2h); }

TEST_CASE("time_error exact reference: smooth at the chosen step, unlike a supersampled loss", "[time_error]") {
  const TimeErrorScene scene;
  const Directions directions = random_directions(scene.points(), 3, 0, 6);
  const FiniteDifferenceSteps steps{kExactPositionStepPx};

  const Tensor exact_target = exact_scene_image(scene, scene.target_points(), scene.colours()).image;
  const ReferenceDerivatives exact =
      finite_difference_reference(scene, exact_scene_loss(scene, exact_target), directions, steps);
  // Smooth loss: the 2nd-order truncation error f''' h^2 / 6 is ~3e-5 relative at 0.01 px.
  CHECK(spread(exact) < 1e-3);

  // A point-sampled 4x4 render's loss jumps where edges cross subsamples; at
  // the same step its differences are dominated by those jumps.
  const RenderSettings ss4{DType::Float64, false, 4};
  const Tensor ss_target = scene.render(scene.target_points(), scene.colours(), ss4);
  const ReferenceDerivatives supersampled =
      finite_difference_reference(scene, rendered_loss(scene, ss_target, ss4), directions, steps);
  CHECK(spread(supersampled) > 1e-2);
}

TEST_CASE("time_error exact reference: the antialiased float64 gradient is within 10% of it", "[time_error]") {
  const TimeErrorScene scene;
  const Directions directions = random_directions(scene.points(), 4, 2, 6);
  const Tensor target = exact_scene_image(scene, scene.target_points(), scene.colours()).image;
  const ReferenceDerivatives exact = finite_difference_reference(scene, exact_scene_loss(scene, target), directions,
                                                                 FiniteDifferenceSteps{kExactPositionStepPx});
  Tensor points = scene.points().detach().set_requires_grad();
  Tensor colours = scene.colours().detach().set_requires_grad();
  backward(scene.loss(points, colours, target, {DType::Float64, true, 4}));
  const double position_error = relative_l2(project(points.grad(), directions.position), exact.position);
  const double colour_error = relative_l2(project(colours.grad(), directions.colour), exact.colour);
  INFO("position " << position_error << ", colour " << colour_error);
  CHECK(position_error < 0.1);
  CHECK(colour_error < 0.05);
}

// Visible area (px^2) of each object of the scene, rendering exactly the
// objects in `only` (all if empty) with the given culling.
std::vector<double> visible_area(const TimeErrorScene& scene, raster::Cull cull, const std::vector<int>& only = {}) {
  NoGradGuard no_grad;
  const int parts = scene.num_parts();
  const std::int64_t p = scene.num_points();
  const std::int32_t* part = scene.point_part().data<std::int32_t>();
  std::vector<double> indicator(static_cast<std::size_t>(p * parts), 0.0);
  for (std::int64_t i = 0; i < p; ++i) indicator[i * parts + part[i]] = 1;
  const Tensor attributes = scene.vertex_colours(Tensor::from_values(indicator, {p, parts}, DType::Float64));
  const std::vector<double> vertex_part = attributes.to_vector();
  const std::int32_t* t = scene.triangles().data<std::int32_t>();
  std::vector<std::int32_t> kept;
  for (std::int64_t i = 0; i < scene.num_triangles(); ++i) {
    int object = 0;
    while (vertex_part[t[3 * i] * parts + object] == 0) ++object;
    if (only.empty() || std::find(only.begin(), only.end(), object) != only.end())
      kept.insert(kept.end(), t + 3 * i, t + 3 * i + 3);
  }
  ExactReferenceOptions options;
  options.cull = cull;
  const ExactImage exact = exact_box_filtered(
      scene.clip_positions(scene.points()), Tensor::from_vector(kept, {std::int64_t(kept.size() / 3), 3}), attributes,
      scene.width(), scene.height(), Tensor::from_values(std::vector<double>(parts, 0.0), {parts}, DType::Float64),
      options);
  std::vector<double> area(parts, 0.0);
  const std::vector<double> image = exact.image.to_vector();
  for (std::size_t i = 0; i < image.size(); ++i) area[i % parts] += image[i];
  return area;
}

TEST_CASE("time_error scenes: the objects show, hide each other or are culled as built", "[time_error]") {
  {
    const TimeErrorScene scene("intersection");  // square, then sphere
    REQUIRE(scene.num_parts() == 2);
    const std::vector<double> both = visible_area(scene, raster::Cull::None);
    const std::vector<double> sphere = visible_area(scene, raster::Cull::None, {1});
    INFO("square " << both[0] << " px^2, sphere " << both[1] << " of " << sphere[1] << " alone");
    CHECK(both[0] > 3000);
    CHECK(both[1] > 1500);
    // Sunk into the square: seen from above, the square hides the strip of
    // the lower half between the near intersection curve and the silhouette
    // (about 115 px^2 as built), no more.
    CHECK(sphere[1] - both[1] > 50);
    CHECK(both[1] > 0.8 * sphere[1]);
  }
  {
    const TimeErrorScene scene("occlusion");  // large sphere, then the small one in front
    REQUIRE(scene.num_parts() == 2);
    const std::vector<double> both = visible_area(scene, raster::Cull::None);
    const std::vector<double> back = visible_area(scene, raster::Cull::None, {0});
    const std::vector<double> front = visible_area(scene, raster::Cull::None, {1});
    INFO("back " << both[0] << " of " << back[0] << ", front " << both[1] << " of " << front[1]);
    CHECK(both[1] == Approx(front[1]).epsilon(1e-9));  // nothing hides the front sphere
    CHECK(both[0] < 0.85 * back[0]);                    // it hides part of the back one...
    CHECK(both[0] > 0.5 * back[0]);                     // ...not most of it
    CHECK(both[1] > 800);
  }
  {
    const TimeErrorScene scene("open_culled");
    REQUIRE(scene.cull() == raster::Cull::Back);
    const double culled = visible_area(scene, raster::Cull::Back)[0];
    const double all = visible_area(scene, raster::Cull::None)[0];
    INFO("culled " << culled << " px^2, not culled " << all);
    CHECK(culled > 1500);
    CHECK(culled < 0.85 * all);  // the inside seen through the opening is culled
  }
}

TEST_CASE("time_error scenes: the exact loss is smooth at the chosen step on every scene", "[time_error]") {
  for (const std::string& name : time_error_scene_names()) {
    const TimeErrorScene scene(name);
    const Directions directions = random_directions(scene.points(), 2, 0, 6);
    const Tensor target = exact_scene_image(scene, scene.target_points(), scene.colours()).image;
    const ReferenceDerivatives exact = finite_difference_reference(scene, exact_scene_loss(scene, target), directions,
                                                                   FiniteDifferenceSteps{kExactPositionStepPx});
    INFO(name << ": spread " << spread(exact));
    CHECK(spread(exact) < 5e-3);
    // The target differs from the image: the loss has something to fit.
    const Tensor image = exact_scene_image(scene, scene.points(), scene.colours()).image;
    CHECK(exact_scene_loss(scene, target)(scene.points(), scene.colours()) > 1e-4);
    CHECK(image.size(0) == 128);
  }
  CHECK_THROWS_AS(TimeErrorScene("no_such_scene"), ValueError);
}

TEST_CASE("time_error regions: each scene's boundary pixels are of the kinds it is built to show", "[time_error]") {
  const auto count = [](const std::vector<int>& regions) {
    std::vector<int> n(kNumPixelRegions, 0);
    for (int r : regions) ++n.at(static_cast<std::size_t>(r));
    return n;
  };
  const TimeErrorScene torus("torus"), intersection("intersection"), occlusion("occlusion");
  const std::vector<int> t = count(pixel_regions(torus, torus.points()));
  const std::vector<int> i = count(pixel_regions(intersection, intersection.points()));
  const std::vector<int> o = count(pixel_regions(occlusion, occlusion.points()));
  // One object: its silhouette against the background, no other object.
  CHECK(t[kBackgroundBoundary] > 300);
  CHECK(t[kObjectChange] == 0);
  // The sphere sunk into the square: the visible half of the curve, > 50 px long.
  CHECK(i[kObjectChange] > 50);
  // The small sphere before the big one: a depth jump along its silhouette.
  CHECK(o[kDepthJump] > 50);
  CHECK(o[kObjectChange] == 0);
  const std::vector<int> regions = pixel_regions(occlusion, occlusion.points());
  const std::vector<std::uint8_t> flags = boundary_pixels(regions);
  REQUIRE(flags.size() == regions.size());
  std::size_t mismatches = 0;
  for (std::size_t k = 0; k < flags.size(); ++k) mismatches += flags[k] != (regions[k] != kInterior);
  CHECK(mismatches == 0);
  CHECK(std::count(flags.begin(), flags.end(), 1) == o[kBackgroundBoundary] + o[kDepthJump]);
}

}  // namespace
}  // namespace gr
