// gradraster-intersection: recovers the height of a sphere sunk into a floor
// from one top-down image, once with visibility_antialias and once with
// antialias alone, and prints both runs' height errors (issue 13 item 5).
//
//   gradraster-intersection [--iterations N] [--size PX]
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "examples/common/cli_args.h"
#include "examples/intersection/intersection_args.h"
#include "examples/intersection/sunk_sphere.h"

using namespace gr::intersection_example;

int main(int argc, char** argv) {
  IntersectionArgs args;
  try {
    args = parse_intersection_args(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const gr::cli::UsageError& e) {
    std::fprintf(stderr, "gradraster-intersection: %s\n(run gradraster-intersection --help for usage)\n", e.what());
    return 2;
  }
  if (args.help) {
    std::fputs(intersection_usage().c_str(), stdout);
    return 0;
  }
  const SunkSphereOptions& options = args.options;
  std::printf("sphere of radius 0.5 sunk into a floor, seen from above (%d x %d); true height %.3f, start %.3f\n",
              options.size, options.size, options.true_height, options.start_height);
  try {
    for (bool visibility : {true, false}) {
      const SunkSphereRun run = fit_sunk_sphere(options, visibility);
      std::printf("%-21s height error %.4f -> %.6f after %d iterations (loss %.3g -> %.3g)\n",
                  visibility ? "visibility_antialias:" : "antialias:",
                  std::abs(run.height.front() - options.true_height),
                  std::abs(run.final_height() - options.true_height), options.iterations, run.loss.front(),
                  run.loss.back());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gradraster-intersection: %s\n", e.what());
    return 1;
  }
  return 0;
}
