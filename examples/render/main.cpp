// gradraster-render: renders an OBJ or builtin mesh with gradraster and writes
// a shaded PNG and the raw G-buffer (see --help and docs/tools.md, "gradraster-render").
// All the work is in render_tool.cpp, so the tests can drive it in-process.
#include <iostream>
#include <string>
#include <vector>

#include "examples/render/render_tool.h"
#include "raster/temporaries.h"

int main(int argc, char** argv) {
  gr::raster::remove_temporaries_on_signals();  // Ctrl-C leaves no partial file behind
  const std::vector<std::string> args(argv + 1, argv + argc);
  return gr::render_tool::run_render_tool(args, std::cout, std::cerr);
}
