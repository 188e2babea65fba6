// The intersection example (examples/intersection/) on a small default: the
// sunk sphere's height converges with visibility_antialias and does not move
// with antialias alone; its command line takes whole numbers only.
#include <catch2/catch.hpp>

#include <cmath>

#include "examples/common/cli_args.h"
#include "examples/intersection/intersection_args.h"
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

TEST_CASE("intersection example: flags take whole numbers in range - anything else is a usage error naming the flag",
          "[examples][intersection]") {
  const IntersectionArgs a = parse_intersection_args({"--iterations", "12", "--size=64"});
  CHECK(!a.help);
  CHECK(a.options.iterations == 12);
  CHECK(a.options.size == 64);
  CHECK(parse_intersection_args({"--help"}).help);
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
      {{"--size", "1e3"}, "--size: expected an integer, got '1e3'"},
      {{"--size", "64abc"}, "--size: expected an integer, got '64abc'"},
      {{"--iterations", "0"}, "--iterations: must lie in 1..4096"},
      {{"--size", "4"}, "--size: must lie in 8..4096"},
      {{"--size"}, "--size: missing value"},
      {{"--size", "64", "--size", "32"}, "--size: given more than once"},
      {{"--fast"}, "unknown option '--fast'"},
      {{"64"}, "unexpected argument '64'"},
  };
  for (const auto& [args, message] : bad) {
    INFO(args[0]);
    CHECK_THROWS_WITH(parse_intersection_args(args), Catch::StartsWith(message));
  }
}
