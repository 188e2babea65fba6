#include "examples/intersection/intersection_args.h"

#include <set>

#include "examples/common/cli_args.h"

namespace gr::intersection_example {

std::string intersection_usage() {
  return R"(Usage: gradraster-intersection [--iterations N] [--size PX]

Recovers the height of a sphere sunk into a floor from one top-down image, once
with visibility_antialias and once with antialias alone, and prints both runs'
height errors (only the first converges: the intersection curve is no mesh edge).

  --iterations N   Adam steps per run, 1..4096 (default 150)
  --size PX        image width and height, 8..4096 (default 96)
  --help           this text

Writes no file. Exit codes: 0 success, 1 runtime error, 2 usage error.
)";
}

IntersectionArgs parse_intersection_args(const std::vector<std::string>& args) {
  IntersectionArgs a;
  std::set<std::string> seen;
  a.help = !cli::for_each_flag(
      args, {{"--iterations", "--size"}, {}},
      [&](const std::string& flag, const std::string& value) {
        if (flag == "--iterations") a.options.iterations = cli::parse_int(flag, value, 1, 4096);
        else a.options.size = cli::parse_int(flag, value, 8, 4096);
      },
      seen);
  return a;
}

}  // namespace gr::intersection_example
