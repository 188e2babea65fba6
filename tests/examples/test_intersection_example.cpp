// The intersection example (examples/intersection/) on a small default: the
// sunk sphere's height converges with visibility_antialias and does not move
// with antialias alone.
#include <catch2/catch.hpp>

#include <cmath>

#include "examples/intersection/sunk_sphere.h"

using namespace gr::intersection_example;

TEST_CASE("intersection example: the sunk sphere's height converges with visibility_antialias and stays put with "
          "antialias alone",
          "[examples][intersection]") {
  SunkSphereOptions options;
  options.size = 48;
  options.iterations = 60;
  const SunkSphereRun vis = fit_sunk_sphere(options, true);
  const SunkSphereRun aa = fit_sunk_sphere(options, false);
  const double start_error = std::abs(options.start_height - options.true_height);
  INFO("visibility_antialias final height " << vis.final_height() << ", antialias " << aa.final_height());
  CHECK(std::abs(vis.final_height() - options.true_height) < 0.1 * start_error);
  CHECK(vis.loss.back() < 0.05 * vis.loss.front());
  CHECK(aa.final_height() == options.start_height);  // no gradient reaches the height
}
