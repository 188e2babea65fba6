// Command-line flags of gradraster-fit, parsed into FitOptions. Kept apart
// from main() so tests can check the parsing and its errors.
#pragma once

#include <string>
#include <vector>

#include "examples/fit/fit.h"

namespace fit {

struct CommandLine {
  enum class Action { Run, Help, Error } action = Action::Run;
  FitOptions options;
  bool profile = false;  // --profile: print where the loop's time went
  std::string device = "cpu";  // --device: where the G-buffers are made (cpu or vulkan)
  std::string error;  // for Action::Error
};

// args excludes the program name.
CommandLine parse_command_line(const std::vector<std::string>& args);
std::string usage(const std::string& program);

}  // namespace fit
