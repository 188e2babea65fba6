// The time_error scene through the exact box-filtered reference renderer
// (bench/exact_reference/, docs/exact_reference.md), and the loss time_error
// grades against: mean((B[f] - T)^2) with B[f] the exact area integral of
// the continuous image over each pixel. The exact loss is a smooth function
// of the vertices, so its finite differences converge as h^2 (h the step).
#pragma once

#include "bench/exact_reference/exact_reference.h"
#include "bench/time_error_reference.h"
#include "bench/time_error_scene.h"

namespace gr::bench {

// Position step of finite differences of the exact loss: 0.01 px of screen
// motion per vertex. On the torus, 8 directions, the h vs 2h spread of the
// 2nd-order differences is 1.9e-2 at 0.25 px, 9.4e-4 at 0.05 px and 3.0e-5 at
// 0.01 px (docs/exact_reference.md), i.e. the truncation error falls as h^2;
// the 4th-order stencil's is O(h^4), far below that spread.
constexpr double kExactPositionStepPx = 0.01;

// The exact box-filtered image ([H, W, 3] float64, over the scene's
// background) and coverage of the scene with the given points and colours
// ([P, 3] float64), culled as the scene's render is (options.cull is replaced
// by scene.cull()).
ExactImage exact_scene_image(const TimeErrorScene& scene, const Tensor& points, const Tensor& colours,
                         const ExactReferenceOptions& options = {});

// mean((exact_scene_image(points, colours).image - target)^2) over pixels and channels.
SceneLoss exact_scene_loss(const TimeErrorScene& scene, const Tensor& target);

}  // namespace gr::bench
