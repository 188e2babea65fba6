// Argument parsing for gradraster-render over the examples' common flag
// handling (examples/common/cli_args.h); every value is checked here, and
// every error message starts with the flag it is about.
#include "examples/render/render_args.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>

namespace gr::render_tool {
namespace {

using cli::fail;
using cli::parse_int;
using cli::parse_number;
using cli::quoted;

// Numbers separated by commas and/or whitespace.
std::vector<double> parse_list(const std::string& flag, const std::string& text) {
  std::vector<double> values;
  std::string token;
  auto flush = [&] {
    if (!token.empty()) values.push_back(parse_number(flag, token));
    token.clear();
  };
  for (char c : text) {
    if (c == ',' || c == ' ' || c == '\t' || c == '\n' || c == '\r')
      flush();
    else
      token += c;
  }
  flush();
  return values;
}

std::array<double, 3> parse_vec3(const std::string& flag, const std::string& text) {
  const std::vector<double> v = parse_list(flag, text);
  if (v.size() != 3) fail(flag, "expected three numbers x,y,z, got " + quoted(text));
  return {v[0], v[1], v[2]};
}

double norm3(const std::array<double, 3>& a) { return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]); }

// a / |a| without overflow for huge components; zero stays zero.
std::array<double, 3> unit(const std::array<double, 3>& a) {
  const double m = std::max({std::fabs(a[0]), std::fabs(a[1]), std::fabs(a[2])});
  if (!(m > 0)) return {0, 0, 0};
  const std::array<double, 3> s = {a[0] / m, a[1] / m, a[2] / m};
  const double n = norm3(s);
  return {s[0] / n, s[1] / n, s[2] / n};
}

}  // namespace

std::string builtin_name(Builtin b) {
  switch (b) {
    case Builtin::Cube: return "cube";
    case Builtin::Sphere: return "sphere";
    case Builtin::Torus: return "torus";
    case Builtin::Plane: return "plane";
    case Builtin::None: break;
  }
  return "none";
}

std::string usage() {
  return R"(Usage: gradraster-render (--mesh FILE.obj | --builtin cube|sphere|torus|plane)
                         [--width W] [--height H]
                         [--mvp "16 column-major floats" | --eye x,y,z [--target x,y,z] [--up x,y,z] [--fov DEG]]
                         [--out image.png] [--out-triid FILE] [--out-depth FILE]
                         [--cull none|back|front] [--flat] [--subdiv S] [--threads N] [--repeat N]
                         [--device cpu|vulkan]

Rasterizes a mesh with gradraster (float32, OpenGL clip conventions) and writes
a Lambert-shaded PNG and/or the raw G-buffer.

Geometry
  --mesh FILE.obj     Wavefront OBJ; polygons are triangulated in file order
  --builtin NAME      cube (edge 2), sphere (icosphere, radius 1), torus (R 1, r 0.25),
                      plane (2 x 2 in z = 0, facing +z)
  --subdiv S          builtin tessellation, 0..8: sphere = icosphere(S) (default 4),
                      torus = 16*2^S x 4*2^S segments (default 4), plane = 2^S x 2^S
                      cells (default 0), cube = S 1-to-4 subdivisions (default 0)
Image
  --width W, --height H   image size in pixels, 1..16384 each (default 512)
Camera (at most one of; without either, the mesh is framed: its bounding sphere
seen from (0.35, 0.25, 1) with a 40.1 degree vertical field of view)
  --mvp "m0 ... m15"  4x4 matrix, column-major (element (r,c) = m[4c+r]), commas or
                      spaces, applied to the model positions as given: clip = MVP * (p, 1)
  --eye x,y,z         perspective(fov, W/H, near, far) * look_at(eye, target, up);
                      --target defaults to 0,0,0, --up to 0,1,0, --fov (vertical,
                      degrees, 0 < fov < 180) to 45. near/far enclose the mesh's
                      bounding sphere: far = 1.01 (d + r), near = max(0.99 (d - r),
                      0.001 far) with d = |eye - centre|, r = radius.
Outputs (written atomically; none is required, e.g. for timing with --repeat; none
may be the mesh, the texture its MTL names, or another output; Ctrl-C leaves no
partial file)
  --out FILE.png      Lambert shading (headlight, two-sided), dark grey background
  --out-triid FILE    W*H little-endian uint32, row 0 = top: 0 = background,
                      k+1 = the k-th triangle (file order after triangulation)
  --out-depth FILE    W*H little-endian float32 window depth 0.5*z_ndc + 0.5
                      (1.0 on background), row 0 = top
Options
  --cull MODE         none (default), back or front (front = counter-clockwise in NDC)
  --flat              face normals even where the mesh has vertex normals
  --threads N         worker threads (0 = all hardware threads, the default)
  --repeat N          rasterize N times and print rasterize_ms=<median> (rasterize only)
  --device cpu|vulkan where the G-buffer is made (default cpu); vulkan: the first GPU
                      (GRADRASTER_VULKAN_DEVICE picks one by name), the same bits
  --help              this text

stdout: one line of mesh/camera facts, one line of rasterizer statistics, and
rasterize_ms=<median> with --repeat. Exit codes: 0 success, 1 runtime error
(unreadable or malformed mesh, unwritable output), 2 usage error.
)";
}

RenderArgs parse_args(const std::vector<std::string>& args) {
  RenderArgs a;
  std::set<std::string> seen;
  bool has_subdiv = false;

  // Flags that take a value, with what they do with it.
  const std::map<std::string, std::function<void(const std::string&, const std::string&)>> valued = {
      {"--mesh",
       [&](const std::string& f, const std::string& v) {
         if (v.empty()) fail(f, "expected a file name");
         a.mesh_path = v;
       }},
      {"--builtin",
       [&](const std::string& f, const std::string& v) {
         if (v == "cube") a.builtin = Builtin::Cube;
         else if (v == "sphere") a.builtin = Builtin::Sphere;
         else if (v == "torus") a.builtin = Builtin::Torus;
         else if (v == "plane") a.builtin = Builtin::Plane;
         else fail(f, "expected cube, sphere, torus or plane, got " + quoted(v));
       }},
      {"--subdiv",
       [&](const std::string& f, const std::string& v) {
         a.subdiv = parse_int(f, v, 0, 8);
         has_subdiv = true;
       }},
      {"--width", [&](const std::string& f, const std::string& v) { a.width = parse_int(f, v, 1, 16384); }},
      {"--height", [&](const std::string& f, const std::string& v) { a.height = parse_int(f, v, 1, 16384); }},
      {"--mvp",
       [&](const std::string& f, const std::string& v) {
         const std::vector<double> m = parse_list(f, v);
         if (m.size() != 16)
           fail(f, "expected 16 numbers (column-major 4x4), got " + std::to_string(m.size()));
         for (int r = 0; r < 4; ++r)
           for (int c = 0; c < 4; ++c) a.mvp_row_major[r * 4 + c] = m[c * 4 + r];
         a.has_mvp = true;
       }},
      {"--eye",
       [&](const std::string& f, const std::string& v) {
         a.eye = parse_vec3(f, v);
         a.has_eye = true;
       }},
      {"--target", [&](const std::string& f, const std::string& v) { a.target = parse_vec3(f, v); }},
      {"--up", [&](const std::string& f, const std::string& v) { a.up = parse_vec3(f, v); }},
      {"--fov",
       [&](const std::string& f, const std::string& v) {
         a.fov_deg = parse_number(f, v);
         if (!(a.fov_deg > 0 && a.fov_deg < 180)) fail(f, "must lie strictly between 0 and 180 degrees, got " + v);
       }},
      {"--out",
       [&](const std::string& f, const std::string& v) {
         if (v.empty()) fail(f, "expected a file name");
         a.out_png = v;
       }},
      {"--out-triid",
       [&](const std::string& f, const std::string& v) {
         if (v.empty()) fail(f, "expected a file name");
         a.out_triid = v;
       }},
      {"--out-depth",
       [&](const std::string& f, const std::string& v) {
         if (v.empty()) fail(f, "expected a file name");
         a.out_depth = v;
       }},
      {"--cull",
       [&](const std::string& f, const std::string& v) {
         if (v == "none") a.cull = raster::Cull::None;
         else if (v == "back") a.cull = raster::Cull::Back;
         else if (v == "front") a.cull = raster::Cull::Front;
         else fail(f, "expected none, back or front, got " + quoted(v));
       }},
      {"--threads", [&](const std::string& f, const std::string& v) { a.threads = parse_int(f, v, 0, 1024); }},
      {"--repeat", [&](const std::string& f, const std::string& v) { a.repeat = parse_int(f, v, 1, 100000); }},
      {"--device",
       [&](const std::string& f, const std::string& v) {
         if (v != "cpu" && v != "vulkan") fail(f, "expected cpu or vulkan, got " + quoted(v));
         a.vulkan = v == "vulkan";
       }},
  };

  cli::Flags flags{{}, {"--flat"}};
  for (const auto& entry : valued) flags.valued.insert(entry.first);
  const bool run = cli::for_each_flag(
      args, flags,
      [&](const std::string& flag, const std::string& value) {
        if (flag == "--flat") a.flat = true;
        else valued.at(flag)(flag, value);
      },
      seen);
  if (!run) {
    a.help = true;
    return a;
  }

  // Required and conflicting flags.
  if (a.mesh_path.empty() == (a.builtin == Builtin::None))
    throw UsageError(a.mesh_path.empty() ? "--mesh or --builtin: one is required"
                                         : "--mesh and --builtin: give only one");
  if (has_subdiv && a.builtin == Builtin::None) fail("--subdiv", "applies only to --builtin meshes");
  if (a.has_mvp && a.has_eye) throw UsageError("--mvp and --eye: give only one camera");
  if (!a.has_eye)
    for (const char* f : {"--target", "--up", "--fov"})
      if (seen.count(f)) fail(f, "applies only with --eye");
  if (a.has_eye) {
    const std::array<double, 3> d = {a.target[0] - a.eye[0], a.target[1] - a.eye[1], a.target[2] - a.eye[2]};
    if (!std::isfinite(d[0]) || !std::isfinite(d[1]) || !std::isfinite(d[2]))
      fail("--eye", "too far from --target (the distance overflows)");
    const std::array<double, 3> du = unit(d), uu = unit(a.up);
    if (!(norm3(du) > 0)) fail("--target", "must differ from --eye");
    if (!(norm3(uu) > 0)) fail("--up", "must not be the zero vector");
    // On unit vectors, so that a far --eye does not overflow the test.
    const std::array<double, 3> c = {du[1] * uu[2] - du[2] * uu[1], du[2] * uu[0] - du[0] * uu[2],
                                     du[0] * uu[1] - du[1] * uu[0]};
    if (!(norm3(c) > 1e-6)) fail("--up", "must not be parallel to the viewing direction (target - eye)");
  }
  return a;
}

}  // namespace gr::render_tool
