// gradraster-intersection's command line over the examples' common flag
// handling (examples/common/cli_args.h): whole numbers only ("1e3" and
// "64abc" are errors, not 1 and 64), unknown flags refused, --help.
#pragma once

#include <string>
#include <vector>

#include "examples/intersection/sunk_sphere.h"

namespace gr::intersection_example {

struct IntersectionArgs {
  bool help = false;
  SunkSphereOptions options;
};

std::string intersection_usage();

// args excludes the program name. Throws cli::UsageError naming the flag.
IntersectionArgs parse_intersection_args(const std::vector<std::string>& args);

}  // namespace gr::intersection_example
