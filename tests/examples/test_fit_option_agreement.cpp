// examples/fit/option_agreement.h: what the processes of an MPI fit must agree
// on, and the message naming the first option that differs (the collective
// itself runs under mpirun in tests/mpi).
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "examples/fit/cli.h"
#include "examples/fit/option_agreement.h"

using fit::first_difference;
using fit::OptionList;
using fit::parse_command_line;
using fit::run_shaping_options;

namespace {

OptionList options_of(const std::vector<std::string>& args) { return run_shaping_options(parse_command_line(args)); }

}  // namespace

TEST_CASE("option agreement: defaults spelled out agree, --out and --threads may differ", "[examples][fit][mpi]") {
  CHECK(options_of({}) == options_of({"--iterations", "300", "--size", "128", "--views", "6", "--mode", "shape"}));
  CHECK(options_of({"--out", "a", "--threads", "1"}) == options_of({"--out", "b", "--threads", "2"}));
  CHECK(first_difference({options_of({"--out", "a"}), options_of({"--out", "b"}), options_of({})}).empty());
}

TEST_CASE("option agreement: every run-shaping option that differs is named, with both values",
          "[examples][fit][mpi]") {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--iterations", "8"}, "--iterations is 8 on process 2 but 300 on process 0"},
      {{"--mode", "pose"}, "--mode is pose on process 2 but shape on process 0"},
      {{"--size", "64"}, "--size is 64 on process 2 but 128 on process 0"},
      {{"--views", "3"}, "--views is 3 on process 2 but 6 on process 0"},
      {{"--subdivisions", "2"}, "--subdivisions is 2 on process 2"},
      {{"--fit", "texture"}, "--fit is texture on process 2 but colours on process 0"},
      {{"--fit-camera"}, "--fit-camera is on on process 2 but off on process 0"},
      {{"--seed", "7"}, "--seed is 7 on process 2 but 1 on process 0"},
      {{"--mesh", "m.obj"}, "--mesh is 'm.obj' on process 2 but (built-in object) on process 0"},
      {{"--mesh", "m.obj", "--texture", "t.png"}, "--mesh is 'm.obj' on process 2"},
      {{"--size", "1e3"}, "the command line is the error '--size: expected an integer, got '1e3'' on process 2 "
                          "but valid on process 0"},
      {{"--help"}, "the command line is --help on process 2 but valid on process 0"},
  };
  for (const auto& [args, expected] : cases) {
    INFO(args[0]);
    const std::string message = first_difference({options_of({}), options_of({}), options_of(args)});
    CHECK_THAT(message, Catch::StartsWith("the processes were started with different options: ") &&
                            Catch::Contains(expected) && Catch::Contains("only --out and --threads may differ"));
  }
}
