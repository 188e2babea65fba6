// parse_command_line over the examples' common flag handling
// (examples/common/cli_args.h): --flag VALUE or --flag=VALUE, whole numbers.
#include "examples/fit/cli.h"

#include <set>
#include <sstream>

#include "examples/common/cli_args.h"

namespace fit {

std::string usage(const std::string& program) {
  std::ostringstream s;
  s << "usage: " << program << " [options]\n"
    << "Inverse rendering through rasterize -> interpolate -> texture -> Lambert -> antialias, with Adam.\n"
    << "  shape mode (default): a grey sphere is fitted to target images of a textured object from\n"
    << "    several views: free vertex positions (+ Laplacian smoothness), vertex colours or a texture,\n"
    << "    optionally a rigid correction of each camera.\n"
    << "  pose mode: recovers the rotation and translation of the object from one image.\n\n"
    << "  --mode shape|pose    what to fit (default shape)\n"
    << "  --mesh FILE.obj      reference object (default: a built-in lobed blob), scaled into the\n"
    << "                       unit sphere; textured if it has uvs and a texture (its MTL's map_Kd or\n"
    << "                       --texture), else painted with a procedural stripe pattern. A missing\n"
    << "                       MTL or texture is a warning on stderr naming the file (the run goes on\n"
    << "                       with the pattern: OBJ files often name materials they do not ship)\n"
    << "  --texture FILE       the reference's texture: PNG, JPEG, BMP or TGA (overrides the OBJ's\n"
    << "                       map_Kd); needs --mesh with uvs (vt): given otherwise it is an error,\n"
    << "                       not ignored, since you asked for it\n"
    << "  --fit colours|texture  shape mode: fit vertex colours (default) or a 128x256 texture\n"
    << "  --fit-camera         shape mode: start every camera ~2 deg / 0.03 off and fit a correction\n"
    << "  --iterations N       optimization steps (default " << kDefaultShapeIterations << " shape, "
    << kDefaultPoseIterations << " pose)\n"
    << "  --size PX            image width and height (default 128)\n"
    << "  --views N            shape mode: cameras around the object (default 6)\n"
    << "  --subdivisions N     shape mode: start icosphere subdivisions, 20*4^N triangles (default 4)\n"
    << "  --out DIR            output folder (default out); the files appear there only when the\n"
    << "                       run succeeds; none may be an input (--mesh, --texture, the MTL's\n"
    << "                       texture); an interrupted run (Ctrl-C, SIGTERM) leaves nothing behind\n"
    << "  --threads N          worker threads, 0 = all (default 0)\n"
    << "  --seed N             pose mode: the pose and its start error; --fit-camera: the camera errors\n"
    << "                       (default 1)\n"
    << "  --profile            print the loop's wall time per phase, in ms per iteration (with\n"
    << "                       --device vulkan also the G-buffers made, read and uploaded there)\n"
    << "  --device cpu|vulkan  where the G-buffers are made (default cpu); vulkan: the first GPU\n"
    << "                       (GRADRASTER_VULKAN_DEVICE picks one by name), the same results\n"
    << "  --help               this message\n"
    << "Writes snapshot_NNNN.png (target | current | |difference|, one row per view), loss.png and\n"
    << "fitted.obj (pose mode: posed.obj; with --fit texture also fitted.mtl, fitted_texture.png).\n"
    << "Exit codes: 0 success, 1 runtime error (e.g. unreadable mesh), 2 usage error.\n";
  return s.str();
}

CommandLine parse_command_line(const std::vector<std::string>& args) {
  CommandLine cl;
  FitOptions& o = cl.options;
  using gr::cli::fail;
  using gr::cli::parse_int;
  auto set = [&](const std::string& flag, const std::string& v) {
    if (flag == "--fit-camera") o.fit_camera = true;
    else if (flag == "--profile") cl.profile = true;
    else if (flag == "--iterations") o.iterations = parse_int(flag, v, 1, 1000000);
    else if (flag == "--size") o.size = parse_int(flag, v, 16, 4096);
    else if (flag == "--views") o.views = parse_int(flag, v, 1, 64);
    else if (flag == "--threads") o.threads = parse_int(flag, v, 0, 1024);
    else if (flag == "--seed") o.seed = static_cast<std::uint64_t>(gr::cli::parse_integer(flag, v, 0, 1LL << 62));
    else if (flag == "--subdivisions") o.start_subdivisions = parse_int(flag, v, 0, 6);
    else if (flag == "--out" || flag == "--mesh" || flag == "--texture") {
      if (v.empty()) fail(flag, flag == "--out" ? "expected a folder" : "expected a file name");
      (flag == "--out" ? o.out_dir : flag == "--mesh" ? o.mesh_path : o.texture_path) = v;
    } else if (flag == "--device") {
      if (v != "cpu" && v != "vulkan") fail(flag, "expected cpu or vulkan, got " + gr::cli::quoted(v));
      cl.device = v;
    } else if (flag == "--mode") {
      if (v != "shape" && v != "pose") fail(flag, "expected shape or pose, got " + gr::cli::quoted(v));
      o.mode = v == "shape" ? Mode::Shape : Mode::Pose;
    } else {  // --fit
      if (v != "colours" && v != "colors" && v != "texture")
        fail(flag, "expected colours or texture, got " + gr::cli::quoted(v));
      o.appearance = v == "texture" ? Appearance::Texture : Appearance::Colours;
    }
  };
  const gr::cli::Flags flags{{"--iterations", "--size", "--views", "--threads", "--seed", "--out", "--mesh",
                              "--texture", "--mode", "--fit", "--subdivisions", "--device"},
                             {"--fit-camera", "--profile"}};
  try {
    std::set<std::string> seen;
    if (!gr::cli::for_each_flag(args, flags, set, seen)) cl.action = CommandLine::Action::Help;
    else if (!o.texture_path.empty() && o.mesh_path.empty())
      fail("--texture", "applies only with --mesh (the built-in object wears its own pattern)");
  } catch (const gr::cli::UsageError& e) {
    cl.action = CommandLine::Action::Error;
    cl.error = e.what();
  }
  return cl;
}

}  // namespace fit
