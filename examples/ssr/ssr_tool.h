// gradraster-ssr as a function: main() is a wrapper around run_ssr_tool, and
// the tests call it directly with an argument list and string streams.
//
//   std::ostringstream out, err;
//   int code = gr::ssr_tool::run_ssr_tool({"--out", "out", "--width", "64", "--height", "48"}, out, err);
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace gr::ssr_tool {

// Exit codes, as for gradraster-render.
constexpr int kExitOk = 0;
constexpr int kExitRuntime = 1;
constexpr int kExitUsage = 2;

// The --help text.
std::string usage();

// Runs the tool on `args` (without the program name): renders the SSR scene
// and writes <out>/ssr_example.png and <out>/ssr_example_viewspace.png
// together (or neither). Never throws.
int run_ssr_tool(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace gr::ssr_tool
