// The intersection example's core (issue 13 item 5): recover the height of a
// sphere sunk into a floor from one image, by gradient descent on the image
// loss. Seen from straight above, the sphere's silhouette (its equator) is
// under the floor, so the only image edge that depends on the height is the
// intersection circle, which is no mesh edge: with visibility_antialias the
// height converges, with antialias alone it gets no gradient and stays.
#pragma once

#include <vector>

namespace gr::intersection_example {

struct SunkSphereOptions {
  int size = 96;               // image width and height (pixels)
  int iterations = 150;        // Adam steps per run
  double true_height = -0.2;   // sphere centre above the floor (z = 0); radius 0.5
  double start_height = -0.35;
  double learning_rate = 0.01;
};

struct SunkSphereRun {
  bool visibility = false;           // visibility_antialias (true) or antialias (false)
  std::vector<double> height;        // after each step (height[0] = start)
  std::vector<double> loss;          // before each step
  double final_height() const { return height.back(); }
};

// One optimization run from start_height towards the target image rendered at
// true_height (with the same op).
SunkSphereRun fit_sunk_sphere(const SunkSphereOptions& options, bool visibility);

}  // namespace gr::intersection_example
