// time_error's exact reference (bench/time_error_exact.h): finite differences
// of the exact box-filtered loss on the torus converge at the chosen step,
// where those of a supersampled render do not, and the antialiased analytic
// gradient lands near them.
#include <catch2/catch.hpp>

#include <cmath>

#include "autodiff/tape.h"
#include "bench/time_error_exact.h"
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

}  // namespace
}  // namespace gr
