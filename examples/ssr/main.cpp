// gradraster-ssr: screen-space reflections on a glossy floor (see --help and
// docs/ssr.md). All the work is in ssr_tool.cpp, so the tests can drive it.
#include <iostream>
#include <string>
#include <vector>

#include "examples/ssr/ssr_tool.h"
#include "raster/temporaries.h"

int main(int argc, char** argv) {
  gr::raster::remove_temporaries_on_signals();  // Ctrl-C leaves no partial file behind
  const std::vector<std::string> args(argv + 1, argv + argc);
  return gr::ssr_tool::run_ssr_tool(args, std::cout, std::cerr);
}
