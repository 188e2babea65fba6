// bench/time_error_args.h: time_error has --help, refuses unknown arguments
// and bad scene names before any work, and refuses outputs that would
// overwrite each other.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "bench/time_error_args.h"
#include "examples/common/cli_args.h"

using gr::bench::check_time_error_outputs;
using gr::bench::parse_time_error_args;
using gr::bench::TimeErrorArgs;

TEST_CASE("time_error args: --help, the defaults, a scene, the output paths and the studies", "[bench][time_error]") {
  CHECK(parse_time_error_args({"--help"}).action == TimeErrorArgs::Action::Help);
  CHECK(parse_time_error_args({"--scene", "torus", "-h"}).action == TimeErrorArgs::Action::Help);
  CHECK_THAT(gr::bench::time_error_usage(), Catch::StartsWith("Usage: time_error"));
  const TimeErrorArgs defaults = parse_time_error_args({});
  CHECK(defaults.action == TimeErrorArgs::Action::Sweep);
  CHECK(defaults.scenes.size() == 4);
  CHECK(defaults.csv_path == "out/time_error.csv");
  CHECK(defaults.png_path == "out/time_error.png");
  const TimeErrorArgs one = parse_time_error_args({"--scene", "occlusion", "--supersampled-reference", "a.csv", "a.png"});
  CHECK(one.scenes == std::vector<std::string>{"occlusion"});
  CHECK(one.supersampled_reference);
  CHECK(one.csv_path == "a.csv");
  CHECK(one.png_path == "a.png");
  const TimeErrorArgs study = parse_time_error_args({"--convergence"});
  CHECK(study.action == TimeErrorArgs::Action::Convergence);
  CHECK(study.scenes == std::vector<std::string>{"torus"});
}

TEST_CASE("time_error args: unknown or misplaced arguments are usage errors naming them", "[bench][time_error]") {
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
      {{"--helpp"}, "unknown option '--helpp'"},
      {{"-x"}, "unknown option '-x'"},
      {{"--scene", "teapot"}, "--scene: expected torus, intersection, occlusion or open_culled, got 'teapot'"},
      {{"--scene"}, "--scene: missing value"},
      {{"--scene", "torus", "--scene", "occlusion"}, "--scene: given more than once"},
      {{"a.csv", "a.png", "extra"}, "unexpected argument 'extra'"},
      {{"--convergence", "--soft-consistency"}, "--soft-consistency: give only one"},
      {{"--convergence", "a.csv"}, "--convergence: prints only"},
      {{"--soft-consistency", "--supersampled-reference"}, "--supersampled-reference: applies only to the sweep"},
  };
  for (const auto& [args, message] : bad) {
    INFO(args[0]);
    CHECK_THROWS_AS(parse_time_error_args(args), gr::cli::UsageError);
    CHECK_THROWS_WITH(parse_time_error_args(args), Catch::StartsWith(message));
  }
}

TEST_CASE("time_error args: outputs that would overwrite each other are refused", "[bench][time_error][distinct_files]") {
  CHECK_NOTHROW(check_time_error_outputs(parse_time_error_args({})));
  CHECK_THROWS_WITH(check_time_error_outputs(parse_time_error_args({"x.png", "./x.png"})),
                    Catch::Contains("the torus plot") && Catch::Contains("two outputs cannot share a file"));
  // Another scene's plot is named after OUT.png: out_occlusion.png.
  CHECK_THROWS_WITH(check_time_error_outputs(parse_time_error_args({"out_occlusion.png", "out.png"})),
                    Catch::Contains("the occlusion plot"));
  CHECK_NOTHROW(check_time_error_outputs(parse_time_error_args({"--scene", "torus", "out_occlusion.png", "out.png"})));
  CHECK_THROWS_WITH(check_time_error_outputs(parse_time_error_args({"time_error_scene_torus.png", "t.png"})),
                    Catch::Contains("the torus picture"));
}
