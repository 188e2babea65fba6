// gradraster-render as a function: main() is a two-line wrapper around
// run_render_tool, and the tests call it directly with an argument list and
// string streams.
//
//   std::ostringstream out, err;
//   int code = gr::render_tool::run_render_tool(
//       {"--builtin", "cube", "--width", "64", "--height", "64", "--eye", "3,2,4", "--out", "cube.png"},
//       out, err);
#pragma once

#include <array>
#include <ostream>
#include <string>
#include <vector>

#include "raster/mesh.h"

namespace gr::render_tool {

// Exit codes.
constexpr int kExitOk = 0;
constexpr int kExitRuntime = 1;  // unreadable/malformed mesh, unwritable output, ...
constexpr int kExitUsage = 2;    // bad command line

// Runs the tool on `args` (without the program name). Normal output (facts,
// statistics, rasterize_ms=..., --help) goes to `out`; warnings and error
// messages go to `err`. Returns the exit code. Never throws.
// With --threads the thread limit is restored before returning.
int run_render_tool(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// Near and far planes that enclose the sphere (centre, radius) seen from
// `eye`: far = 1.01 (d + r), near = max(0.99 (d - r), 0.001 far), d = |eye - centre|.
// (A degenerate sphere at the eye gives near 0.001, far 1.)
std::array<double, 2> near_far_for_sphere(const std::array<double, 3>& eye, const std::array<double, 3>& centre,
                                          double radius);

// Bounding sphere of the positions: centre of the bounding box, radius the
// largest distance from it.
void bounding_sphere(const raster::Mesh& mesh, std::array<double, 3>& centre, double& radius);

}  // namespace gr::render_tool
