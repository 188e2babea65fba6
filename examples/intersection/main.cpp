// gradraster-intersection: recovers the height of a sphere sunk into a floor
// from one top-down image, once with visibility_antialias and once with
// antialias alone, and prints both runs' height errors (issue 13 item 5).
//
//   gradraster-intersection [--iterations N] [--size PX]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "autodiff/error.h"
#include "examples/intersection/sunk_sphere.h"

using namespace gr::intersection_example;

int main(int argc, char** argv) {
  SunkSphereOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--iterations" || a == "--size") && i + 1 < argc) {
      const int v = std::atoi(argv[++i]);
      if (v < 1 || v > 4096) {
        std::fprintf(stderr, "gradraster-intersection: %s must be in [1, 4096]\n", a.c_str());
        return 2;
      }
      (a == "--iterations" ? options.iterations : options.size) = v;
    } else {
      std::fprintf(stderr, "usage: gradraster-intersection [--iterations N] [--size PX]\n");
      return a == "--help" ? 0 : 2;
    }
  }
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
  } catch (const gr::Error& e) {
    std::fprintf(stderr, "gradraster-intersection: %s\n", e.what());
    return 1;
  }
  return 0;
}
