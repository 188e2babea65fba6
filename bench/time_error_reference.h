// The reference gradient of time_error (docs/time_error.md): directional
// derivatives of the float64 loss rendered at high supersampling with
// antialiasing, by central finite differences along fixed-seed random
// directions (the random projections of autodiff/gradcheck.h), and the
// relative L2 error of a gradient's projections against them.
#pragma once

#include <cstdint>
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

struct FiniteDifferenceOptions {
  RenderSettings settings{DType::Float64, true, 16};
  // Position step as the typical screen displacement of a vertex, in pixels
  // (converted with scene.pixels_per_unit()); a step spans several subpixels,
  // so it averages over the kinks where edges cross subpixel centres.
  double position_step_px = 0.25;
  double colour_step = 0.05;  // the loss is quadratic in the colours: 2-point differences are exact
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
// colour: [L(h) - L(-h)] / 2 h. All in float64 without the tape.
ReferenceDerivatives finite_difference_reference(const TimeErrorScene& scene, const Tensor& target,
                                                 const Directions& directions, const FiniteDifferenceOptions& options);

// grad . v for each direction (grad of any float dtype, accumulated in double).
std::vector<double> project(const Tensor& grad, const std::vector<Tensor>& directions);
// |a - r|_2 / |r|_2.
double relative_l2(const std::vector<double>& a, const std::vector<double>& r);

}  // namespace gr::bench
