// parse_command_line: --flag VALUE pairs (or --flag=VALUE), strict integers.
#include "examples/fit/cli.h"

#include <algorithm>
#include <cerrno>
#include <iterator>
#include <cstdlib>
#include <sstream>

namespace fit {

namespace {

// Parses a whole string as an integer in [lo, hi].
bool parse_int(const std::string& text, long long lo, long long hi, long long& value) {
  if (text.empty()) return false;
  char* end = nullptr;
  errno = 0;
  value = std::strtoll(text.c_str(), &end, 10);
  return errno == 0 && *end == '\0' && value >= lo && value <= hi;
}

}  // namespace

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
    << "                       --texture), else painted with a procedural stripe pattern\n"
    << "  --texture FILE.png   the reference's texture (overrides the OBJ's map_Kd)\n"
    << "  --fit colours|texture  shape mode: fit vertex colours (default) or a 128x256 texture\n"
    << "  --fit-camera         shape mode: start every camera ~2 deg / 0.03 off and fit a correction\n"
    << "  --iterations N       optimization steps (default " << kDefaultShapeIterations << " shape, "
    << kDefaultPoseIterations << " pose)\n"
    << "  --size PX            image width and height (default 128)\n"
    << "  --views N            shape mode: cameras around the object (default 6)\n"
    << "  --subdivisions N     shape mode: start icosphere subdivisions, 20*4^N triangles (default 4)\n"
    << "  --out DIR            output folder (default out)\n"
    << "  --threads N          worker threads, 0 = all (default 0)\n"
    << "  --seed N             pose mode: the pose and its start error; --fit-camera: the camera errors\n"
    << "                       (default 1)\n"
    << "  --help               this message\n"
    << "Writes snapshot_NNNN.png (target | current | |difference|, one row per view), loss.png and\n"
    << "fitted.obj (pose mode: posed.obj; with --fit texture also fitted.mtl, fitted_texture.png).\n"
    << "Exit codes: 0 success, 1 runtime error (e.g. unreadable mesh), 2 usage error.\n";
  return s.str();
}

CommandLine parse_command_line(const std::vector<std::string>& args) {
  CommandLine cl;
  auto fail = [&](const std::string& message) {
    cl.action = CommandLine::Action::Error;
    cl.error = message;
    return cl;
  };
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string flag = args[i], value;
    bool has_value = false;
    if (const auto eq = flag.find('='); flag.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = flag.substr(eq + 1), flag = flag.substr(0, eq), has_value = true;
    }
    if (flag == "--help" || flag == "-h") {
      cl.action = CommandLine::Action::Help;
      return cl;
    }
    if (flag == "--fit-camera") {
      if (has_value) return fail("--fit-camera takes no value");
      cl.options.fit_camera = true;
      continue;
    }
    static const char* const kValueFlags[] = {"--iterations", "--size", "--views", "--threads", "--seed", "--out",
                                              "--mesh", "--texture", "--mode", "--fit", "--subdivisions"};
    if (std::find(std::begin(kValueFlags), std::end(kValueFlags), flag) == std::end(kValueFlags))
      return fail(flag.rfind("--", 0) == 0 ? "unknown option '" + flag + "'" : "unexpected argument '" + flag + "'");
    if (!has_value) {
      if (i + 1 >= args.size()) return fail(flag + " needs a value");
      value = args[++i];
    }
    long long n = 0;
    FitOptions& o = cl.options;
    if (flag == "--iterations") {
      if (!parse_int(value, 1, 1000000, n)) return fail("--iterations wants an integer in [1, 1000000], got '" + value + "'");
      o.iterations = int(n);
    } else if (flag == "--size") {
      if (!parse_int(value, 16, 4096, n)) return fail("--size wants an integer in [16, 4096], got '" + value + "'");
      o.size = int(n);
    } else if (flag == "--views") {
      if (!parse_int(value, 1, 64, n)) return fail("--views wants an integer in [1, 64], got '" + value + "'");
      o.views = int(n);
    } else if (flag == "--threads") {
      if (!parse_int(value, 0, 1024, n)) return fail("--threads wants an integer in [0, 1024], got '" + value + "'");
      o.threads = int(n);
    } else if (flag == "--seed") {
      if (!parse_int(value, 0, (1LL << 62), n)) return fail("--seed wants a non-negative integer, got '" + value + "'");
      o.seed = static_cast<std::uint64_t>(n);
    } else if (flag == "--out") {
      if (value.empty()) return fail("--out wants a folder");
      o.out_dir = value;
    } else if (flag == "--mesh") {
      if (value.empty()) return fail("--mesh wants an OBJ file");
      o.mesh_path = value;
    } else if (flag == "--texture") {
      if (value.empty()) return fail("--texture wants an image file");
      o.texture_path = value;
    } else if (flag == "--mode") {
      if (value == "shape") o.mode = Mode::Shape;
      else if (value == "pose") o.mode = Mode::Pose;
      else return fail("--mode wants shape or pose, got '" + value + "'");
    } else if (flag == "--fit") {
      if (value == "colours" || value == "colors") o.appearance = Appearance::Colours;
      else if (value == "texture") o.appearance = Appearance::Texture;
      else return fail("--fit wants colours or texture, got '" + value + "'");
    } else if (flag == "--subdivisions") {
      if (!parse_int(value, 0, 6, n)) return fail("--subdivisions wants an integer in [0, 6], got '" + value + "'");
      o.start_subdivisions = int(n);
    } else {
      return fail("unknown option '" + flag + "'");
    }
  }
  return cl;
}

}  // namespace fit
