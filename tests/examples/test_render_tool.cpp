// Tests of the gradraster-render tool (examples/render/), driven in-process
// through run_render_tool: the files it writes (sizes, byte layout, content at
// known pixels), triangle ids in OBJ file order under a column-major --mvp, the
// --eye camera agreeing with the same matrix passed as --mvp, usage and runtime
// errors naming the flag without leaving files, and the --repeat timing line.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include "autodiff/base/memory.h"
#include "autodiff/base/parallel.h"
#include "examples/render/render_tool.h"
#include "ops/tensor/linalg.h"
#include "ops/render/transforms.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/temp_dir.h"

using namespace gr;
using gr::render_tool::run_render_tool;
using gr::testing::slurp;
using gr::testing::TempDir;

namespace {

struct Run {
  int code = -1;
  std::string out, err;
};

Run render(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  Run r;
  r.code = run_render_tool(args, out, err);
  r.out = out.str();
  r.err = err.str();
  return r;
}

// Raw little-endian uint32 / float32 buffers as written by --out-triid / --out-depth.
std::vector<std::uint32_t> read_u32(const std::string& path) {
  const std::string bytes = slurp(path);
  std::vector<std::uint32_t> v(bytes.size() / 4);
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int b = 0; b < 4; ++b) v[i] |= std::uint32_t(static_cast<unsigned char>(bytes[4 * i + b])) << (8 * b);
  return v;
}

std::vector<float> read_f32(const std::string& path) {
  std::vector<float> f;
  for (std::uint32_t u : read_u32(path)) {
    float x;
    std::memcpy(&x, &u, 4);
    f.push_back(x);
  }
  return f;
}

// The value after "key=" on any line of `text` ("" if absent).
std::string value_of(const std::string& text, const std::string& key) {
  std::istringstream in(text);
  std::string word;
  while (in >> word)
    if (word.rfind(key + "=", 0) == 0) return word.substr(key.size() + 1);
  return "";
}

std::string full_precision(double x) {
  std::ostringstream s;
  s << std::setprecision(17) << x;
  return s.str();
}

}  // namespace

TEST_CASE("render tool: the builtin cube gives a PNG and W*H raw tri_id/depth values with the cube in the middle",
          "[examples][render]") {
  TempDir dir;
  const int w = 64, h = 48;  // not square, so a transposed buffer would show
  const Run r = render({"--builtin", "cube", "--width", std::to_string(w), "--height", std::to_string(h), "--eye",
                        "3,2,4", "--out", dir.file("cube.png"), "--out-triid", dir.file("cube.tri"), "--out-depth",
                        dir.file("cube.depth")});
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(value_of(r.out, "triangles_in") == "12");
  CHECK(value_of(r.out, "rasterized") == "12");
  CHECK(value_of(r.out, "rasterize_ms").empty());  // only with --repeat

  REQUIRE(std::filesystem::file_size(dir.file("cube.tri")) == std::uintmax_t(4 * w * h));
  REQUIRE(std::filesystem::file_size(dir.file("cube.depth")) == std::uintmax_t(4 * w * h));
  const std::vector<std::uint32_t> id = read_u32(dir.file("cube.tri"));
  const std::vector<float> depth = read_f32(dir.file("cube.depth"));
  const int centre = (h / 2) * w + w / 2, corner = 0, last = w * h - 1;
  CHECK(id[centre] >= 1);
  CHECK(id[centre] <= 12);
  CHECK(depth[centre] > 0.0f);
  CHECK(depth[centre] < 1.0f);
  for (int p : {corner, w - 1, last}) {
    CHECK(id[p] == 0);
    CHECK(depth[p] == 1.0f);
  }
  // Covered pixels are exactly those with depth < 1.
  std::int64_t covered = 0;
  for (int p = 0; p < w * h; ++p) {
    CHECK((id[p] != 0) == (depth[p] < 1.0f));
    covered += id[p] != 0;
  }
  CHECK(value_of(r.out, "covered_pixels") == std::to_string(covered));

  const Tensor png = raster::read_image(dir.file("cube.png"));
  REQUIRE(png.shape() == Shape{h, w, 3});
  CHECK(png.at({0, 0, 0}) == Approx(0.2).margin(0.01));  // dark grey background
  CHECK(png.at({h / 2, w / 2, 0}) > 0.3);               // a lit face
}

TEST_CASE("render tool: an OBJ under a column-major --mvp gets tri_ids in file order and window depths",
          "[examples][render]") {
  TempDir dir;
  // Face 1: a quad at z = 0.5, fanned into triangles 1 (v1 v2 v3, below the
  // diagonal y = x) and 2 (v1 v3 v4). Face 2: triangle 3 at z = -0.5 (nearer),
  // below the line y = 2x - 1, overlapping the quad's lower right corner.
  const std::string obj = dir.write("scene.obj",
                                    "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n"
                                    "v 0 -1 -0.5\nv 1 -1 -0.5\nv 1 1 -0.5\n"
                                    "f 1 2 3 4\nf 5 6 7\n");
  // Identity plus a translation of +0.25 in x, given column-major (m[12] = tx).
  const std::string mvp = "1 0 0 0  0 1 0 0  0 0 1 0  0.25 0 0 1";
  const int n = 8;
  const Run r = render({"--mesh", obj, "--width", "8", "--height", "8", "--mvp", mvp, "--out-triid",
                        dir.file("id.raw"), "--out-depth", dir.file("depth.raw")});
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(value_of(r.out, "triangles_in") == "3");
  const std::vector<std::uint32_t> id = read_u32(dir.file("id.raw"));
  const std::vector<float> depth = read_f32(dir.file("depth.raw"));
  REQUIRE(id.size() == std::size_t(n * n));
  REQUIRE(depth.size() == std::size_t(n * n));

  int checked = 0;
  for (int row = 0; row < n; ++row)
    for (int col = 0; col < n; ++col) {
      // Pixel centre in model coordinates (undo the viewport and the translation).
      const double x = (col + 0.5) / n * 2 - 1 - 0.25, y = 1 - (row + 0.5) / n * 2;
      if (x == y && std::abs(x) < 0.5) continue;  // on the quad's diagonal: the tie rule decides
      std::uint32_t want = 0;
      float want_depth = 1.0f;
      if (x >= 0 && x <= 1 && y >= -1 && y <= 2 * x - 1) {
        want = 3, want_depth = 0.25f;
      } else if (std::abs(x) < 0.5 && std::abs(y) < 0.5) {
        want = y < x ? 1 : 2, want_depth = 0.75f;
      }
      INFO("pixel (" << col << ", " << row << ")");
      CHECK(id[row * n + col] == want);
      CHECK(depth[row * n + col] == Approx(want_depth).margin(1e-6));
      ++checked;
    }
  CHECK(checked == n * n - 4);
  // A few named pixels, as a reader would check them by hand.
  CHECK(id[0] == 0);           // top left: background
  CHECK(id[3 * n + 3] == 2);   // upper left of the quad
  CHECK(id[5 * n + 4] == 1);   // lower right of the quad
  CHECK(id[5 * n + 6] == 3);   // the nearer triangle in front of the quad
  CHECK(id[4 * n + 7] == 3);
}

TEST_CASE("render tool: --eye gives the same G-buffer as perspective * look_at passed as --mvp",
          "[examples][render]") {
  TempDir dir;
  const int w = 40, h = 30;
  const std::array<double, 3> eye = {2.5, 1.5, 3.0};
  std::array<double, 3> centre;
  double radius;
  render_tool::bounding_sphere(raster::make_torus(16 << 4, 4 << 4), centre, radius);
  const auto nf = render_tool::near_far_for_sphere(eye, centre, radius);
  CHECK(nf[0] > 0);
  CHECK(nf[1] > nf[0]);
  auto vec = [](const std::array<double, 3>& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}, DType::Float64); };
  const Tensor m = matmul(perspective(30.0 * M_PI / 180, double(w) / h, nf[0], nf[1], ClipSpace::OpenGL, DType::Float64),
                          look_at(vec(eye), vec({0, 0, 0}), vec({0, 1, 0})));
  std::string mvp;
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) mvp += full_precision(m.at({row, c})) + " ";

  const Run a = render({"--builtin", "torus", "--width", std::to_string(w), "--height", std::to_string(h), "--eye",
                        "2.5,1.5,3", "--fov", "30", "--out-triid", dir.file("a.raw")});
  const Run b = render({"--builtin", "torus", "--width", std::to_string(w), "--height", std::to_string(h), "--mvp",
                        mvp, "--out-triid", dir.file("b.raw")});
  INFO(a.err << b.err);
  REQUIRE(a.code == 0);
  REQUIRE(b.code == 0);
  const std::string ids = slurp(dir.file("a.raw"));
  CHECK(ids.size() == std::size_t(4 * w * h));
  CHECK(ids == slurp(dir.file("b.raw")));
  CHECK(std::stoll(value_of(a.out, "covered_pixels")) > 0);
}

TEST_CASE("render tool: back-face culling is off by default and --cull back drops the hidden half of a sphere",
          "[examples][render]") {
  const std::vector<std::string> base = {"--builtin", "sphere", "--subdiv", "2", "--width", "32", "--height", "32",
                                         "--eye", "0,0,3"};
  const Run none = render(base);
  std::vector<std::string> culled = base;
  culled.insert(culled.end(), {"--cull", "back"});
  const Run back = render(culled);
  REQUIRE(none.code == 0);
  REQUIRE(back.code == 0);
  CHECK(value_of(none.out, "culled_face") == "0");
  CHECK(std::stoll(value_of(back.out, "culled_face")) > 100);
  CHECK(value_of(none.out, "covered_pixels") == value_of(back.out, "covered_pixels"));
}

TEST_CASE("render tool: bad arguments exit with 2 and a message naming the flag, writing nothing",
          "[examples][render]") {
  TempDir dir;
  const std::string out = dir.file("x.png");
  const std::vector<std::string> ok = {"--builtin", "cube", "--width", "16", "--height", "16", "--eye", "3,2,4"};
  struct Case {
    std::vector<std::string> extra;  // after "--out x.png" and ok, or without ok if `alone`
    bool alone;
    std::string names;
  };
  const std::vector<Case> cases = {
      {{"--bogus", "1"}, false, "--bogus"},
      {{"--width", "12"}, false, "--width"},  // given twice
      {{"--builtin", "cube", "--width", "0x10", "--height", "16", "--eye", "3,2,4"}, true, "--width"},
      {{"--builtin", "cube", "--width", "16", "--height", "-3", "--eye", "3,2,4"}, true, "--height"},
      {{"--builtin", "cube", "--width", "16", "--height", "16385", "--eye", "3,2,4"}, true, "--height"},
      {{"--builtin", "cone", "--width", "16", "--height", "16", "--eye", "3,2,4"}, true, "--builtin"},
      {{"--width", "16", "--height", "16", "--eye", "3,2,4"}, true, "--mesh or --builtin"},
      {{"--builtin", "cube", "--width", "16", "--height", "16", "--fov", "30"}, true, "--fov"},  // without --eye
      {{"--builtin", "cube", "--width", "16", "--height", "16", "--eye", "1,2"}, true, "--eye"},
      {{"--builtin", "cube", "--width", "16", "--height", "16", "--eye", "1,2,nan"}, true, "--eye"},
      {{"--builtin", "cube", "--width", "16", "--height", "16", "--eye"}, true, "--eye"},
      {{"--builtin", "cube", "--width", "16", "--height", "16", "--mvp", "1 0 0 1"}, true, "--mvp"},
      {{"--mvp", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"}, false, "--mvp and --eye"},
      {{"--fov", "0"}, false, "--fov"},
      {{"--fov", "abc"}, false, "--fov"},
      {{"--up", "3,2,4"}, false, "--up"},  // parallel to the view direction
      {{"--target", "3,2,4"}, false, "--target"},
      {{"--cull", "sideways"}, false, "--cull"},
      {{"--threads", "-1"}, false, "--threads"},
      {{"--repeat", "0"}, false, "--repeat"},
      {{"--device", "cuda"}, false, "--device"},
      {{"--repeat"}, false, "--repeat"},  // missing value
      {{"--subdiv", "9"}, false, "--subdiv"},
      {{"--flat=yes"}, false, "--flat"},
      {{"stray"}, false, "stray"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"--out", out};
    if (!c.alone) args.insert(args.end(), ok.begin(), ok.end());
    args.insert(args.end(), c.extra.begin(), c.extra.end());
    const Run r = render(args);
    INFO("expected a message naming " << c.names << "; got: " << r.err);
    CHECK(r.code == 2);
    CHECK(r.err.find(c.names) != std::string::npos);
    CHECK(r.out.empty());
  }
  CHECK(dir.count() == 0);
}

TEST_CASE("render tool: a missing or malformed mesh and an unwritable output exit with 1 naming the flag",
          "[examples][render]") {
  TempDir dir;
  const std::string bad = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  const std::vector<std::string> rest = {"--width", "16", "--height", "16", "--eye", "0,0,3", "--out",
                                         dir.file("x.png"), "--out-triid", dir.file("x.raw")};
  for (const std::string& mesh : {dir.file("missing.obj"), bad}) {
    std::vector<std::string> args = {"--mesh", mesh};
    args.insert(args.end(), rest.begin(), rest.end());
    const Run r = render(args);
    INFO(r.err);
    CHECK(r.code == 1);
    CHECK(r.err.find("--mesh") != std::string::npos);
  }
  const Run r = render({"--builtin", "plane", "--width", "16", "--height", "16", "--eye", "0,0,3", "--out-depth",
                        dir.file("no/such/folder/d.raw")});
  CHECK(r.code == 1);
  CHECK(r.err.find("--out-depth") != std::string::npos);
  CHECK(dir.count() == 1);  // only bad.obj: no partial outputs
}

TEST_CASE("render tool: --repeat prints the median rasterize time, --threads is restored, --help prints usage",
          "[examples][render]") {
  const int threads_before = num_threads();
  const Run r = render({"--builtin", "sphere", "--width", "64", "--height", "64", "--eye", "0,1,3", "--repeat", "3",
                        "--threads", "1"});
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.out.find("\nrasterize_ms=") != std::string::npos);
  const std::string ms = value_of(r.out, "rasterize_ms");
  REQUIRE(!ms.empty());
  CHECK(std::stod(ms) >= 0.0);
  CHECK(value_of(r.out, "threads") == "1");
  CHECK(num_threads() == threads_before);

  const Run help = render({"--help"});
  CHECK(help.code == 0);
  CHECK(help.out.find("Usage: gradraster-render") != std::string::npos);
  CHECK(help.out.find("--out-depth") != std::string::npos);
}

TEST_CASE("render tool: --mesh without a camera frames the whole mesh", "[examples][render]") {
  TempDir dir;
  gr::raster::Mesh mesh = gr::raster::make_torus(32, 8);
  for (std::int64_t i = 0; i < mesh.positions.numel(); ++i) mesh.positions.data<float>()[i] = 40 + 7 * mesh.positions.data<float>()[i];
  gr::raster::save_obj(dir.file("torus.obj"), mesh);
  const Run r = render({"--mesh", dir.file("torus.obj"), "--out", dir.file("torus.png")});
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(r.out.find("camera=framed") != std::string::npos);
  CHECK(value_of(r.out, "culled_outside") == "0");
  CHECK(std::stoi(value_of(r.out, "covered_pixels")) > 0);
  CHECK(std::filesystem::exists(dir.file("torus.png")));
}

TEST_CASE("render tool: NaN or Inf clip positions from extreme flags name the flag", "[examples][render]") {
  const std::vector<std::string> base = {"--builtin", "cube", "--width", "8", "--height", "8"};
  auto run = [&](std::vector<std::string> extra) {
    extra.insert(extra.begin(), base.begin(), base.end());
    return render(extra);
  };
  const Run fov = run({"--eye", "0,0,3", "--fov", "1e-300"});
  CHECK(fov.code == 1);
  CHECK(fov.err.find("--eye/--fov") != std::string::npos);
  const Run mvp = run({"--mvp", "1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38 1e38"});
  CHECK(mvp.code == 1);
  CHECK(mvp.err.find("--mvp") != std::string::npos);
  // A far --eye is not reported as "--up parallel".
  const Run far = run({"--eye", "1e300,0,0"});
  INFO(far.err);
  CHECK(far.code == 1);
  CHECK(far.err.find("--eye") != std::string::npos);
  CHECK(far.err.find("parallel") == std::string::npos);
  const Run overflow = run({"--eye", "1e308,0,0", "--target", "-1e308,0,0"});
  CHECK(overflow.code == 2);
  CHECK(overflow.err.find("--eye: too far") != std::string::npos);
}

TEST_CASE("render tool: a request over the memory budget is refused before rendering, naming the estimate",
          "[examples][render][memory]") {
  TempDir dir;
  gr::set_memory_limit(gr::memory_in_use() + (std::size_t(16) << 20));
  const Run r = render({"--builtin", "cube", "--width", "4096", "--height", "4096", "--out", dir.file("big.png")});
  gr::set_memory_limit(0);
  INFO(r.err);
  CHECK(r.code == 1);
  CHECK(r.err.find("gradraster-render 4096x4096 needs 769 MiB") != std::string::npos);
  CHECK(r.out.empty());
  CHECK(dir.count() == 0);
}

TEST_CASE("render tool: an output that is the input mesh or another output is refused, touching nothing",
          "[examples][render][distinct_files]") {
  TempDir dir;
  raster::save_obj(dir.file("v.obj"), raster::make_cube());
  const std::string mesh = slurp(dir.file("v.obj"));
  for (const std::string& spelling : {dir.file("v.obj"), dir.file("./v.obj"), dir.file("sub/../v.obj")}) {
    INFO(spelling);
    std::filesystem::create_directories(dir.file("sub"));
    const Run r = render({"--mesh", dir.file("v.obj"), "--width", "8", "--height", "8", "--out-depth", spelling});
    CHECK(r.code == 2);
    CHECK_THAT(r.err, Catch::Contains("--out-depth") && Catch::Contains("is the same file as --mesh"));
    CHECK(slurp(dir.file("v.obj")) == mesh);
  }
  // The same file given to every output: refused, nothing written.
  const Run r = render({"--builtin", "cube", "--width", "8", "--height", "8", "--out", dir.file("x"), "--out-triid",
                        dir.file("x"), "--out-depth", dir.file("./x")});
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Catch::Contains("--out-triid") && Catch::Contains("two outputs cannot share a file"));
  CHECK(!std::filesystem::exists(dir.file("x")));
}

TEST_CASE("render tool: an output that is the texture the mesh's MTL names is refused", "[examples][render][distinct_files]") {
  TempDir dir;
  raster::Mesh cube = raster::make_cube();
  raster::write_png(dir.file("tex.png"), Tensor::full({2, 2, 3}, 0.5));
  cube.texture_path = dir.file("tex.png");
  cube.uvs = Tensor::zeros({cube.num_vertices(), 2});
  raster::save_obj(dir.file("v.obj"), cube);  // writes v.mtl naming tex.png
  const std::string texture = slurp(dir.file("tex.png"));
  const Run r = render({"--mesh", dir.file("v.obj"), "--width", "8", "--height", "8", "--out", dir.file("tex.png")});
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Catch::Contains("the texture named by --mesh"));
  CHECK(slurp(dir.file("tex.png")) == texture);
}

TEST_CASE("render tool: an output that is the mesh's MTL file is refused", "[examples][render][distinct_files]") {
  TempDir dir;
  raster::Mesh cube = raster::make_cube();
  raster::write_png(dir.file("tex.png"), Tensor::full({2, 2, 3}, 0.5));
  cube.texture_path = dir.file("tex.png");
  cube.uvs = Tensor::zeros({cube.num_vertices(), 2});
  raster::save_obj(dir.file("v.obj"), cube);  // writes v.mtl, named by v.obj's mtllib line
  const std::string mtl = slurp(dir.file("v.mtl"));
  const Run r = render({"--mesh", dir.file("v.obj"), "--width", "8", "--height", "8", "--out-depth", dir.file("./v.mtl")});
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Catch::Contains("the MTL file named by --mesh"));
  CHECK(slurp(dir.file("v.mtl")) == mtl);
}

TEST_CASE("render tool: a mesh 1e-14 units across is framed like a unit one - a mesh of one point is refused",
          "[examples][render][mesh_framing]") {
  TempDir dir;
  std::string covered;
  for (double s : {1.0, 1e-14}) {
    CAPTURE(s);
    gr::raster::Mesh mesh = gr::raster::make_icosphere(2);
    float* p = mesh.positions.data<float>();
    for (std::int64_t i = 0; i < mesh.positions.numel(); ++i) p[i] = static_cast<float>(p[i] * s);
    gr::raster::save_obj(dir.file("sphere.obj"), mesh);
    const Run r = render({"--mesh", dir.file("sphere.obj"), "--width", "64", "--height", "64"});
    INFO(r.err);
    REQUIRE(r.code == 0);
    if (s == 1.0) covered = value_of(r.out, "covered_pixels");
    CHECK(value_of(r.out, "covered_pixels") == covered);  // the same picture at any scale
  }
  CHECK(std::stoi(covered) > 500);
  std::ofstream(dir.file("point.obj")) << "v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n";
  const Run point = render({"--mesh", dir.file("point.obj"), "--width", "64", "--height", "64"});
  CHECK(point.code == 1);
  CHECK_THAT(point.err, Catch::Contains("--mesh") && Catch::Contains("lie at one point (1, 2, 3)"));
}
