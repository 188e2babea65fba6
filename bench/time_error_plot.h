// The time-against-error frontier plot of time_error: log-log, one labelled
// point per configuration, the Pareto frontier drawn as a line.
#pragma once

#include <string>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr::bench {

struct FrontierPoint {
  std::string label;  // drawn next to the point
  double ms = 0;      // x
  double error = 0;   // y (> 0; other points are left out)
  bool float64 = false;    // blue, else orange
  bool antialias = false;  // filled disc, else a ring
  bool visibility = false;  // visibility_antialias: a hollow square (drawn around an aa disc at the same spot)
};

// Indices of the points on the Pareto frontier (no other point is both at
// least as fast and at least as accurate, and strictly better in one), by time.
std::vector<std::size_t> pareto_frontier(const std::vector<FrontierPoint>& points);

// [480, 720, 3] float32 image: x = time (ms), y = error, the frontier as a
// black line under the points and a black ring around each frontier point,
// labels placed where they overlap nothing drawn before them (right, left,
// above or below the point), a legend on top.
Tensor plot_frontier(const std::vector<FrontierPoint>& points, const std::string& y_title);

}  // namespace gr::bench
