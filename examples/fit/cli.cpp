// parse_command_line: --flag VALUE pairs (or --flag=VALUE), strict integers.
#include "examples/fit/cli.h"

#include <cerrno>
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
    << "Inverse rendering: fits the vertex colours and vertex positions (offsets along the\n"
    << "normals) of a grey, dented copy of a mesh to Lambert-shaded target images of it\n"
    << "from several views (Adam + Laplacian smoothness).\n\n"
    << "  --iterations N   optimization steps (default 300)\n"
    << "  --size PX        image width and height (default 128)\n"
    << "  --views N        cameras around the object (default 6)\n"
    << "  --out DIR        output folder (default out)\n"
    << "  --threads N      worker threads, 0 = all (default 0)\n"
    << "  --mesh FILE.obj  reference object (default: a built-in bumpy icosphere),\n"
    << "                   scaled into the unit sphere\n"
    << "  --seed N         seed of the start dents (default 1)\n"
    << "  --help           this message\n";
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
    if (!has_value) {
      if (i + 1 >= args.size()) return fail(flag.rfind("--", 0) == 0 ? flag + " needs a value" : "unexpected argument '" + flag + "'");
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
    } else {
      return fail("unknown option '" + flag + "'");
    }
  }
  return cl;
}

}  // namespace fit
