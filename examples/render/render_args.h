// Command-line parsing of gradraster-render: turns the argument list into a
// RenderArgs, or throws UsageError with a message that names the offending
// flag. Parsing checks everything that can be checked without touching files
// (numbers, ranges, required and conflicting flags), so a usage error never
// costs a mesh load or a render.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "examples/common/cli_args.h"
#include "raster/rasterize.h"

namespace gr::render_tool {

// A command-line mistake: reported with the usage hint, exit code 2.
using UsageError = cli::UsageError;

enum class Builtin { None, Cube, Sphere, Torus, Plane };

struct RenderArgs {
  bool help = false;

  // Geometry: exactly one of mesh_path / builtin.
  std::string mesh_path;
  Builtin builtin = Builtin::None;
  std::optional<int> subdiv;  // builtin tessellation level (see usage())

  int width = 512;
  int height = 512;

  // Camera: an MVP (row-major here, converted from the column-major command
  // line), or eye / target / up / fov, or neither: the mesh is framed
  // (gr::examples::frame_mesh).
  bool has_mvp = false;
  std::array<double, 16> mvp_row_major{};
  bool has_eye = false;
  std::array<double, 3> eye{};
  std::array<double, 3> target{0, 0, 0};
  std::array<double, 3> up{0, 1, 0};
  double fov_deg = 45.0;

  std::string out_png;
  std::string out_triid;
  std::string out_depth;

  raster::Cull cull = raster::Cull::None;
  bool flat = false;          // shade with face normals even if the mesh has vertex normals
  std::optional<int> threads; // 0 = all hardware threads
  int repeat = 0;             // 0: no timing line
  bool vulkan = false;        // --device vulkan: the G-buffer on a Vulkan device
};

// The --help text.
std::string usage();

// Parses args (without the program name). Throws UsageError.
RenderArgs parse_args(const std::vector<std::string>& args);

// Name of a builtin mesh as written on the command line.
std::string builtin_name(Builtin b);

}  // namespace gr::render_tool
