// The reference gradient of time_error (docs/time_error.md): directional
// derivatives of a float64 loss (the exact box-filtered one,
// bench/time_error_exact.h, or a supersampled render's), by central finite
// differences along fixed-seed random
// directions (the random projections of autodiff/gradcheck.h), and the
// relative L2 error of a gradient's projections against them.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "bench/time_error_scene.h"

namespace gr::bench {

// Fixed-seed random directions in parameter space, [P, 3] float64 each, with
// entries of unit root mean square. Position directions are smooth random
// displacement fields (each coordinate a sum of 6 sinusoids of the point's
// position, wavelengths about 1 to 4 units on a torus 2.8 units across), so a
// step moves silhouettes coherently, as an optimizer's step does, and the loss
// along them is smooth on the pixel scale; independent noise per vertex would
// flip silhouette edges back and forth and make finite differences depend on
// the step (docs/time_error.md). Colour directions are independent normals.
struct Directions {
  std::vector<Tensor> position;  // move the points (colours fixed)
  std::vector<Tensor> colour;    // change the colours (points fixed)
};
Directions random_directions(const Tensor& points, int num_position, int num_colour, std::uint64_t seed);

// A float64 loss of the parameters (points, colours: [P, 3] float64),
// evaluated off the tape: the function whose derivatives are the reference.
using SceneLoss = std::function<double(const Tensor& points, const Tensor& colours)>;

// mean((render - target)^2) of the scene rendered with the given settings
// (time_error's first reference: float64, antialias, 16x16 supersampling).
SceneLoss rendered_loss(const TimeErrorScene& scene, const Tensor& target, const RenderSettings& settings);

struct FiniteDifferenceSteps {
  // Position step as the typical screen displacement of a vertex, in pixels
  // (converted with scene.pixels_per_unit()). A supersampled loss has kinks
  // where edges cross subpixel centres, so its step must span several
  // subpixels (0.25 px at 16x16); the exact loss is smooth and takes a small
  // one (docs/time_error.md).
  double position_px = 0.25;
  double colour = 0.05;  // the loss is quadratic in the colours: 2-point differences are exact
};

struct ReferenceDerivatives {
  std::vector<double> position;  // d loss / d t of loss(points + t v_k, colours), per direction
  std::vector<double> colour;    // d loss / d t of loss(points, colours + t v_k)
  // The second-order central differences with steps h and 2h (free from the
  // same four evaluations), for judging the step: their relative L2 spread.
  std::vector<double> position_h, position_2h;
  double seconds = 0;  // wall time spent
};

// position: the fourth-order stencil (8 [L(h) - L(-h)] - [L(2h) - L(-2h)]) / 12 h;
// colour: [L(h) - L(-h)] / 2 h, with L = loss at the scene's parameters moved along v_k.
ReferenceDerivatives finite_difference_reference(const TimeErrorScene& scene, const SceneLoss& loss,
                                                 const Directions& directions, const FiniteDifferenceSteps& steps);

// grad . v for each direction (grad of any float dtype, accumulated in double).
std::vector<double> project(const Tensor& grad, const std::vector<Tensor>& directions);
// |a - r|_2 / |r|_2.
double relative_l2(const std::vector<double>& a, const std::vector<double>& r);

}  // namespace gr::bench
