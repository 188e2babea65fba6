// Bad-input catalogue (issue 7, part 2): one test per class of bad input. Each
// asserts the exception type and that the message names the offending
// argument; sizes are refused before any buffer is allocated; file errors
// leave no partial output behind. docs/robustness.md lists the behaviours.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "autodiff/base/memory.h"
#include "autodiff/base/storage.h"
#include "examples/render/render_tool.h"
#include "ops/ops.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/temp_dir.h"

using namespace gr;
using gr::testing::TempDir;

namespace {

// Runs f, requires it to throw exactly E (or a subclass) whose message contains every `parts`.
template <class E, class F>
void require_throw(F&& f, std::initializer_list<std::string> parts) {
  bool thrown = false;
  try {
    f();
  } catch (const E& e) {
    thrown = true;
    const std::string msg = e.what();
    INFO("message: " << msg);
    for (const std::string& p : parts) CHECK(msg.find(p) != std::string::npos);
  } catch (const std::exception& e) {
    FAIL("wrong exception type, message: " << e.what());
  }
  CHECK(thrown);
}

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

// One triangle in front of the camera in clip space (w = 1), 8x8 pixels.
Tensor clip_tri(DType dt = DType::Float32) {
  return Tensor::from_values({-0.8, -0.7, 0.1, 1, 0.9, -0.6, 0.2, 1, 0.0, 0.8, 0.3, 1}, {3, 4}, dt);
}
Tensor one_tri() { return Tensor::from_vector<std::int32_t>({0, 1, 2}, {1, 3}); }

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(in), {});
}
void write_bytes(const std::string& path, const std::vector<unsigned char>& b) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}
bool exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

}  // namespace

TEST_CASE("bad input: NaN or Inf vertex positions and attributes are refused naming the element",
          "[bad_input]") {
  for (double bad : {kNaN, kInf, -kInf}) {
    for (DType dt : {DType::Float32, DType::Float64}) {
      std::vector<double> c = clip_tri(DType::Float64).to_vector();
      c[5] = bad;  // vertex 1, y
      const Tensor clip = Tensor::from_values(c, {3, 4}, dt);
      require_throw<ValueError>([&] { rasterize(clip, one_tri(), {8, 8}); }, {"rasterize", "clip[5]"});
      const GBuffer gb = rasterize(clip_tri(dt), one_tri(), {8, 8});
      require_throw<ValueError>([&] { antialias(Tensor::zeros({8, 8, 3}, dt), gb, clip, one_tri()); },
                                {"antialias", "clip[5]"});
      // Attributes: interpolate names the element of 'attributes'.
      std::vector<double> a(9, 0.5);
      a[4] = bad;
      require_throw<ValueError>(
          [&] { interpolate(Tensor::from_values(a, {3, 3}, dt), gb, one_tri()); },
          {"interpolate", "attributes[4]"});
      // Texture coordinates.
      require_throw<ValueError>(
          [&] { texture(Tensor::ones({4, 4, 3}, dt), Tensor::from_values({0.5, bad}, {1, 2}, dt)); },
          {"texture", "uv[1]"});
    }
    // Model positions through transform_points reach rasterize as NaN clip rows.
    Tensor pos = Tensor::from_values({0, 0, -2, 1, 0, -2, 0, 1, bad}, {3, 3});
    const Tensor clip = transform_points(pos, perspective(1.0, 1.0, 0.1, 10.0));
    require_throw<ValueError>([&] { rasterize(clip, one_tri(), {8, 8}); }, {"rasterize", "clip["});
    // A mesh with a NaN position fails validation naming the field.
    raster::Mesh mesh = raster::make_cube();
    mesh.positions.data<float>()[7] = static_cast<float>(bad);
    require_throw<ValueError>([&] { mesh.validate("my_tool"); }, {"my_tool", "positions"});
  }
}

TEST_CASE("bad input: a NaN or Inf interpolate background is refused naming 'background'", "[bad_input]") {
  for (double bad : {kNaN, kInf, -kInf}) {
    for (DType dt : {DType::Float32, DType::Float64}) {
      INFO(bad << " " << dtype_name(dt));
      RasterizeOptions with_db{8, 8};
      with_db.derivatives = true;
      const GBuffer gb = rasterize(clip_tri(dt), one_tri(), with_db);
      InterpolateOptions o;
      o.background = Tensor::from_values({0.0, 0.5, bad}, {3}, dt);
      // It would fill every uncovered pixel (fuzz corpus: interpolate_accepts_nan_background.bin).
      require_throw<ValueError>([&] { interpolate(Tensor::ones({3, 3}, dt), gb, one_tri(), o); },
                                {"interpolate", "background[2]"});
      require_throw<ValueError>(
          [&] { interpolate_with_derivatives(Tensor::ones({3, 3}, dt), gb, one_tri(), o); },
          {"interpolate", "background[2]"});
    }
  }
}

TEST_CASE("bad input: triangle indices negative or >= the vertex count are refused naming tris[t][k]",
          "[bad_input]") {
  for (std::int32_t bad : {-1, 3, 1 << 30}) {
    const Tensor tris = Tensor::from_vector<std::int32_t>({0, 1, 2, 2, bad, 0}, {2, 3});
    require_throw<IndexError>([&] { rasterize(clip_tri(), tris, {8, 8}); }, {"rasterize", "tris[1][1]"});
    const GBuffer gb = rasterize(clip_tri(), one_tri(), {8, 8});
    require_throw<IndexError>([&] { interpolate(Tensor::ones({3, 2}), gb, tris); },
                              {"interpolate", "tris[1][1]"});
    require_throw<IndexError>([&] { antialias(Tensor::zeros({8, 8, 3}), gb, clip_tri(), tris); },
                              {"antialias", "tris[1][1]"});
    raster::Mesh mesh = raster::make_cube();
    mesh.triangles.data<std::int32_t>()[5] = bad == 3 ? 24 : bad;
    require_throw<IndexError>([&] { mesh.validate("load"); }, {"load", "triangles"});
  }
}

TEST_CASE("bad input: an empty mesh rasterizes to an empty G-buffer, and an OBJ without triangles is an IOError",
          "[bad_input]") {
  TempDir dir;
  for (std::int64_t n : {0, 3}) {
    // Zero triangles (with zero or some vertices) is a valid scene: all background.
    Tensor clip = n ? clip_tri(DType::Float64) : Tensor::zeros({0, 4}, DType::Float64);
    clip.set_requires_grad();
    const Tensor tris = Tensor::zeros({0, 3}, DType::Int32);
    const GBuffer gb = rasterize(clip, tris, {6, 5});
    for (double id : gb.tri_id.to_vector()) CHECK(id == 0);
    for (double d : gb.depth.to_vector()) CHECK(d == raster::kBackgroundDepth);
    CHECK(gb.stats.triangles_in == 0);
    Tensor colours = Tensor::ones({n, 3}, DType::Float64).set_requires_grad();
    Tensor img = interpolate(colours, gb, tris);
    img = antialias(img, gb, clip, tris);
    CHECK(img.shape() == Shape{5, 6, 3});
    for (double x : img.to_vector()) CHECK(x == 0.0);
    backward(sum(img + reshape(gb.depth, {5, 6, 1})));
    for (const Tensor& t : {clip, colours})
      if (t.grad().defined())
        for (double g : t.grad().to_vector()) CHECK(g == 0.0);
  }
  // Files: empty, only vertices, only comments.
  for (const char* text : {"", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "# nothing\n\n"}) {
    const std::string path = dir.write("empty.obj", text);
    require_throw<IOError>([&] { raster::load_obj(path); }, {"load_obj", path, "no triangles"});
  }
}

TEST_CASE("bad input: zero, negative and absurd image sizes are refused before allocating", "[bad_input]") {
  // Every tensor is built before counting, so only the op's own allocations count.
  const Tensor clip = clip_tri();
  const Tensor tris = one_tri();
  const std::vector<std::pair<int, int>> sizes = {{0, 8}, {8, 0}, {-4, 8}, {8, -1}, {100000, 100000},
                                                  {16385, 1}, {16384, 16384 + 1}, {INT32_MAX, INT32_MAX}};
  for (const auto& size : sizes) {
    const int w = size.first, h = size.second;  // not a structured binding: lambdas capture it (C++17, clang)
    INFO(w << " x " << h);
    const std::int64_t before = storage_stats().fresh_allocations;
    require_throw<ValueError>([&] { rasterize(clip, tris, {w, h}); }, {"rasterize", "image size"});
    CHECK(storage_stats().fresh_allocations == before);
  }
  // viewport: no allocation of the image, but the size is still checked.
  require_throw<ValueError>([&] { viewport(Tensor::zeros({3, 3}), 0, 8); }, {"viewport", "width and height"});
  // Textures larger than the texel limit per side are refused (before building a mip pyramid).
  const Tensor tall = Tensor::zeros({40000, 1, 1});
  const Tensor uv = Tensor::zeros({4, 2}), uv_dx = Tensor::zeros({4, 2}), uv_dy = Tensor::zeros({4, 2});
  const std::int64_t before = storage_stats().fresh_allocations;
  require_throw<ValueError>([&] { texture(tall, uv, {Filter::Trilinear}, uv_dx, uv_dy); }, {"texture", "'tex'"});
  CHECK(storage_stats().fresh_allocations == before);
  // An empty image cannot be written.
  TempDir dir;
  require_throw<ShapeError>([&] { raster::write_png(dir.file("e.png"), Tensor::zeros({0, 4, 3})); },
                            {"write_png", "image"});
  CHECK(dir.count() == 0);
  // A PNG whose header claims 100000 x 100000 pixels is refused by the reader, not decoded.
  raster::write_png(dir.file("small.png"), Tensor::full({2, 2, 3}, 0.5));
  std::vector<unsigned char> png = read_bytes(dir.file("small.png"));
  REQUIRE(png.size() > 24);
  for (int k : {16, 20}) {  // IHDR width, height (big-endian)
    png[k] = 0;
    png[k + 1] = 0x01;
    png[k + 2] = 0x86;
    png[k + 3] = 0xA0;
  }
  write_bytes(dir.file("huge.png"), png);
  require_throw<IOError>([&] { raster::read_image(dir.file("huge.png")); }, {"huge.png"});
}

TEST_CASE("bad input: attribute rows that do not match the vertex count are a ShapeError naming 'attributes'",
          "[bad_input]") {
  const GBuffer gb = rasterize(clip_tri(), one_tri(), {8, 8});
  for (std::int64_t n : {2, 4}) {
    require_throw<ShapeError>([&] { interpolate(Tensor::ones({n, 3}), gb, one_tri()); },
                              {"interpolate", "'attributes'", "N = 3"});
  }
  InterpolateOptions o;
  o.background = Tensor::zeros({2});
  require_throw<ShapeError>([&] { interpolate(Tensor::ones({3, 3}), gb, one_tri(), o); },
                            {"interpolate", "background"});
  // An image of another size than the G-buffer.
  require_throw<ShapeError>([&] { antialias(Tensor::zeros({8, 9, 3}), gb, clip_tri(), one_tri()); },
                            {"antialias", "'gbuffer'"});
  // A mesh whose normals or uvs do not have one row per vertex.
  raster::Mesh mesh = raster::make_cube();
  mesh.normals = Tensor::zeros({5, 3});
  require_throw<ShapeError>([&] { mesh.validate("mesh"); }, {"mesh", "normals"});
}

TEST_CASE("bad input: wrong dtype or rank is a DTypeError or ShapeError naming the argument", "[bad_input]") {
  const Tensor tris = one_tri();
  require_throw<DTypeError>([&] { rasterize(Tensor::zeros({3, 4}, DType::Int32), tris, {8, 8}); },
                            {"rasterize", "'clip'"});
  require_throw<ShapeError>([&] { rasterize(Tensor::zeros({3, 3}), tris, {8, 8}); }, {"rasterize", "'clip'"});
  require_throw<ShapeError>([&] { rasterize(Tensor::zeros({1, 3, 4}), tris, {8, 8}); }, {"rasterize", "'clip'"});
  require_throw<DTypeError>([&] { rasterize(clip_tri(), Tensor::zeros({1, 3}), {8, 8}); },
                            {"rasterize", "'triangles'"});
  require_throw<ShapeError>([&] { rasterize(clip_tri(), Tensor::zeros({1, 4}, DType::Int32), {8, 8}); },
                            {"rasterize", "'triangles'"});
  require_throw<ShapeError>([&] { rasterize(clip_tri(), Tensor::zeros({3}, DType::Int32), {8, 8}); },
                            {"rasterize", "'triangles'"});
  const GBuffer gb = rasterize(clip_tri(), tris, {8, 8});
  require_throw<DTypeError>([&] { interpolate(Tensor::ones({3, 3}, DType::Float64), gb, tris); },
                            {"interpolate", "attributes"});
  require_throw<DTypeError>([&] { interpolate(Tensor::ones({3, 3}, DType::Int32), gb, tris); },
                            {"interpolate", "'attributes'"});
  require_throw<ShapeError>([&] { interpolate(Tensor::ones({3}), gb, tris); },
                            {"interpolate", "'attributes'"});
  require_throw<DTypeError>([&] { antialias(Tensor::zeros({8, 8, 3}, DType::Float64), gb, clip_tri(), tris); },
                            {"antialias", "'image'"});
  require_throw<ShapeError>([&] { antialias(Tensor::zeros({8, 8}), gb, clip_tri(), tris); },
                            {"antialias", "'image'"});
  require_throw<DTypeError>([&] { texture(Tensor::ones({4, 4, 3}), Tensor::zeros({2, 2}, DType::Float64)); },
                            {"texture", "'uv'"});
  require_throw<ShapeError>([&] { texture(Tensor::ones({4, 4, 3}), Tensor::zeros({2, 3})); }, {"texture", "'uv'"});
  require_throw<DTypeError>([&] { raster::write_png("unused.png", Tensor::zeros({2, 2, 3}, DType::Int32)); },
                            {"write_png", "image"});
  require_throw<ShapeError>([&] { raster::write_png("unused.png", Tensor::zeros({2, 2, 2, 3})); },
                            {"write_png", "image"});
  CHECK(!exists("unused.png"));
}

TEST_CASE("bad input: textures of size 0 or with mismatched channels are refused naming the argument",
          "[bad_input]") {
  const Tensor uv = Tensor::full({4, 2}, 0.5);
  for (const Shape& s : {Shape{0, 4, 3}, Shape{4, 0, 3}, Shape{4, 4, 0}, Shape{4, 4}})
    require_throw<ShapeError>([&] { texture(Tensor::zeros(s), uv); }, {"texture", "'tex'"});
  require_throw<ShapeError>(
      [&] { texture(Tensor::ones({4, 4, 3}), uv, {Filter::Trilinear}, Tensor::zeros({4, 2}), Tensor::zeros({3, 2})); },
      {"texture", "'uv_dy'"});
  require_throw<ValueError>([&] { texture(Tensor::ones({4, 4, 3}), uv, {Filter::Trilinear}); },
                            {"texture", "'uv_dx'"});
  // A 4-channel (RGBA) texture multiplied with a 3-channel colour: the broadcast names both shapes.
  const Tensor rgba = texture(Tensor::ones({4, 4, 4}), uv);
  require_throw<ShapeError>([&] { mul(rgba, Tensor::ones({4, 3})); }, {"[4, 4]", "[4, 3]"});
  // Asking the reader for an impossible channel count.
  TempDir dir;
  raster::write_png(dir.file("t.png"), Tensor::full({2, 2, 3}, 0.5));
  require_throw<ValueError>([&] { raster::read_image(dir.file("t.png"), 5); }, {"read_image", "channels"});
  CHECK(raster::read_image(dir.file("t.png"), 4).shape() == Shape{2, 2, 4});
}

TEST_CASE("bad input: malformed OBJ files are an IOError naming the file and line, and missing MTL or texture warns",
          "[bad_input]") {
  TempDir dir;
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  struct Bad {
    const char* what;
    std::string text;
    std::string line;
  };
  const std::vector<Bad> bad = {
      {"truncated v line", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"truncated f line", tri + "f 1 2\n", "line 4"},
      {"bad number", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"number with junk", "v 0 0 0\nv 1 0 0\nv 0 1 0.5x\nf 1 2 3\n", "line 3"},
      {"non-finite number", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"face refers to a missing vertex", tri + "f 1 2 9\n", "line 4"},
      {"face index 0", tri + "f 0 1 2\n", "line 4"},
      {"face refers to a missing uv", tri + "vt 0 0\nf 1/1 2/2 3/1\n", "line 5"},
      {"huge index", tri + "f 1 2 99999999999999999999\n", "line 4"},
      {"truncated last line", tri + "f 1 2", "line 4"},
  };
  for (const Bad& b : bad) {
    INFO(b.what);
    const std::string path = dir.write("bad.obj", b.text);
    require_throw<IOError>([&] { raster::load_obj(path); }, {"load_obj", path, b.line});
  }
  require_throw<IOError>([&] { raster::load_obj(dir.file("missing.obj")); }, {"load_obj", "missing.obj"});
  require_throw<IOError>([&] { raster::load_obj(dir.file("")); }, {"load_obj"});
  // Missing MTL file and missing texture: the mesh loads, with a warning naming the file.
  auto require_loads_with_warning = [](const std::string& path, const std::string& missing) {
    const raster::Mesh m = raster::load_obj(path);
    CHECK(m.num_triangles() == 1);
    CHECK(m.texture_path.empty());
    std::string all;
    for (const auto& w : m.warnings) all += w + "\n";
    INFO(all);
    CHECK(all.find(missing) != std::string::npos);
  };
  require_loads_with_warning(dir.write("nomtl.obj", "mtllib nothere.mtl\nusemtl a\n" + tri + "f 1 2 3\n"),
                             "nothere.mtl");
  dir.write("tex.mtl", "newmtl a\nmap_Kd missing_texture.png\n");
  require_loads_with_warning(dir.write("notex.obj", "mtllib tex.mtl\nusemtl a\n" + tri + "f 1 2 3\n"),
                             "missing_texture.png");
}

TEST_CASE("bad input: missing, unreadable, truncated or corrupt PNG files are an IOError naming the path",
          "[bad_input]") {
  TempDir dir;
  raster::write_png(dir.file("good.png"), Tensor::full({4, 5, 3}, 0.25));
  const std::vector<unsigned char> good = read_bytes(dir.file("good.png"));
  REQUIRE(good.size() > 40);
  write_bytes(dir.file("truncated.png"), std::vector<unsigned char>(good.begin(), good.begin() + 40));
  write_bytes(dir.file("header_only.png"), std::vector<unsigned char>(good.begin(), good.begin() + 8));
  std::vector<unsigned char> flipped = good;
  for (std::size_t k = 33; k < flipped.size(); ++k) flipped[k] ^= 0x5A;  // corrupt everything after IHDR
  write_bytes(dir.file("corrupt.png"), flipped);
  write_bytes(dir.file("empty.png"), {});
  write_bytes(dir.file("text.png"), {'h', 'e', 'l', 'l', 'o'});
  for (const char* name : {"missing.png", "truncated.png", "header_only.png", "corrupt.png", "empty.png", "text.png"}) {
    INFO(name);
    require_throw<IOError>([&] { raster::read_image(dir.file(name)); }, {"read image", name});
  }
  require_throw<IOError>([&] { raster::read_image(dir.file("")); }, {"read image"});  // a directory
  if (::geteuid() != 0) {  // root reads files whatever their mode
    ::chmod(dir.file("good.png").c_str(), 0);
    require_throw<IOError>([&] { raster::read_image(dir.file("good.png")); }, {"good.png"});
    ::chmod(dir.file("good.png").c_str(), 0644);
  }
}

TEST_CASE("bad input: a failed write leaves no partial file and keeps an existing one", "[bad_input]") {
  TempDir dir;
  // Unwritable target: a missing folder.
  require_throw<IOError>([&] { raster::write_png(dir.file("no/such/dir/a.png"), Tensor::zeros({2, 2, 3})); },
                         {"a.png"});
  CHECK(dir.count() == 0);
  // A bad image after a good write: the old file stays as it was, no temporaries remain.
  const std::string path = dir.file("keep.png");
  raster::write_png(path, Tensor::full({3, 3, 3}, 0.75));
  const std::vector<unsigned char> before = read_bytes(path);
  require_throw<ShapeError>([&] { raster::write_png(path, Tensor::zeros({3, 3, 7})); }, {"write_png", "image"});
  CHECK(read_bytes(path) == before);
  CHECK(dir.count() == 1);
  // save_obj of an invalid mesh writes nothing.
  raster::Mesh mesh = raster::make_cube();
  mesh.positions.data<float>()[0] = std::numeric_limits<float>::quiet_NaN();
  require_throw<ValueError>([&] { raster::save_obj(dir.file("bad.obj"), mesh); }, {"positions"});
  CHECK(!exists(dir.file("bad.obj")));
  CHECK(dir.count() == 1);
  // The render tool on a malformed OBJ: exit code 1, a message naming the file, no output files.
  const std::string obj = dir.write("broken.obj", "v 0 0 0\nv 1 0\nf 1 2 3\n");
  std::ostringstream out, err;
  const int code = render_tool::run_render_tool({"--mesh", obj, "--width", "16", "--height", "16", "--eye", "0,0,3",
                                                 "--out", dir.file("r.png"), "--out-triid", dir.file("r.tri")},
                                                out, err);
  CHECK(code == render_tool::kExitRuntime);
  CHECK(err.str().find("broken.obj") != std::string::npos);
  CHECK(!exists(dir.file("r.png")));
  CHECK(!exists(dir.file("r.tri")));
  // ... and on an absurd image size: a usage or runtime error, never an allocation.
  std::ostringstream out2, err2;
  const int code2 = render_tool::run_render_tool({"--builtin", "cube", "--width", "100000", "--height", "100000",
                                                  "--eye", "0,0,3", "--out", dir.file("big.png")},
                                                 out2, err2);
  CHECK(code2 != render_tool::kExitOk);
  CHECK(!exists(dir.file("big.png")));
}

TEST_CASE("bad input: FIFOs, devices and /proc files as OBJ, MTL or image inputs are refused naming the file, without hanging",
          "[bad_input][files]") {
  TempDir dir;
  REQUIRE(::mkfifo(dir.file("mesh.obj").c_str(), 0600) == 0);
  require_throw<IOError>([&] { raster::load_obj(dir.file("mesh.obj")); }, {"mesh.obj", "FIFO"});
  REQUIRE(::mkfifo(dir.file("tex.png").c_str(), 0600) == 0);
  require_throw<IOError>([&] { raster::read_image(dir.file("tex.png")); }, {"tex.png", "FIFO"});
  // An mtllib that resolves to /dev/zero or /dev/urandom (read to exhaustion before).
  const std::string tri = "usemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  for (const char* device : {"/dev/zero", "/dev/urandom"}) {
    INFO(device);
    const std::string mtl = dir.file("dev.mtl");
    ::unlink(mtl.c_str());
    REQUIRE(::symlink(device, mtl.c_str()) == 0);
    const std::string obj = dir.write("dev.obj", "mtllib dev.mtl\n" + tri);
    require_throw<IOError>([&] { raster::load_obj(obj); }, {"dev.obj", "dev.mtl", "character device"});
  }
  // A /proc file (regular, size 0) as the mesh: read with a limit, then an ordinary OBJ error.
  require_throw<IOError>([&] { raster::load_obj("/proc/self/status"); }, {"/proc/self/status", "no triangles"});
  // ... and through the render tool: exit 1 naming --mesh and the file.
  std::ostringstream out, err;
  CHECK(render_tool::run_render_tool({"--mesh", dir.file("mesh.obj"), "--width", "8", "--height", "8"}, out, err) ==
        render_tool::kExitRuntime);
  CHECK(err.str().find("--mesh") != std::string::npos);
  CHECK(err.str().find("FIFO") != std::string::npos);
}

TEST_CASE("bad input: an image whose header needs more than the memory budget is refused before decoding",
          "[bad_input][memory]") {
  TempDir dir;
  // A PNG signature and an IHDR for 16384 x 16384 RGB, no pixel data: 4.2 GB decoded.
  std::vector<unsigned char> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                    0, 0, 0x40, 0, 0, 0, 0x40, 0, 8, 2, 0, 0, 0, 0, 0, 0, 0};
  write_bytes(dir.file("huge.png"), png);
  set_memory_limit(memory_in_use() + (std::size_t(64) << 20));
  require_throw<MemoryError>([&] { raster::read_image(dir.file("huge.png")); }, {"huge.png", "16384 x 16384"});
  set_memory_limit(0);
  // Sides beyond the decoder's limit are an IOError naming the size.
  png[18] = 0x80, png[19] = 0x01, png[22] = 0, png[23] = 8;  // 32769 x 8
  write_bytes(dir.file("wide.png"), png);
  require_throw<IOError>([&] { raster::read_image(dir.file("wide.png")); }, {"wide.png", "1..32768"});
}

TEST_CASE("bad input: a truncated PNG names the decoder's reason and the path", "[bad_input]") {
  TempDir dir;
  raster::write_png(dir.file("full.png"), Tensor::full({64, 64, 3}, 0.5));
  const std::vector<unsigned char> good = read_bytes(dir.file("full.png"));
  // Cut inside the last chunk (IEND) or in the middle: stb gave an empty reason for the first.
  for (const std::size_t keep : {good.size() - 12, good.size() - 16, good.size() / 2}) {
    INFO("first " << keep << " bytes");
    write_bytes(dir.file("cut.png"), std::vector<unsigned char>(good.begin(), good.begin() + long(keep)));
    require_throw<IOError>([&] { raster::read_image(dir.file("cut.png")); }, {"cut.png': truncated or corrupt"});
  }
}

TEST_CASE("bad input: OBJ messages quote a bounded, printable prefix of a bad token and name UTF-16",
          "[bad_input][obj]") {
  const std::string huge(1 << 20, '7');
  try {
    raster::load_obj_from_string("v 0 0 0\nv 1 0 0\nv 0 1 x" + huge + "\nf 1 2 3\n", "big.obj");
    FAIL("no error");
  } catch (const IOError& e) {
    const std::string msg = e.what();
    CHECK(msg.size() < 300);
    CHECK(msg.find("line 3") != std::string::npos);
    CHECK(msg.find("...") != std::string::npos);
  }
  // UTF-16 text (with or without a byte-order mark) and NUL bytes.
  std::string utf16 = "\xff\xfe";
  for (char c : std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")) utf16 += std::string{c, '\0'};
  require_throw<IOError>([&] { raster::load_obj_from_string(utf16, "wide.obj"); }, {"wide.obj", "UTF-16", "UTF-8"});
  require_throw<IOError>([&] { raster::load_obj_from_string(utf16.substr(2), "wide.obj"); }, {"line 1", "UTF-16"});
  require_throw<IOError>([&] { raster::load_obj_from_string(std::string("v 0 0 0\nf 1\0 2 3\n", 17)); },
                         {"line 2", "NUL byte"});
}

TEST_CASE("bad input: an output path naming a symlink, FIFO or folder is refused and left untouched",
          "[bad_input][files]") {
  TempDir dir;
  const std::string victim = dir.write("victim.txt", "keep");
  REQUIRE(::symlink(victim.c_str(), dir.file("link.png").c_str()) == 0);
  REQUIRE(::mkfifo(dir.file("fifo.png").c_str(), 0600) == 0);
  for (const char* name : {"link.png", "fifo.png"}) {
    INFO(name);
    require_throw<IOError>([&] { raster::write_png(dir.file(name), Tensor::zeros({2, 2, 3})); }, {name, "refusing"});
    std::ostringstream out, err;
    CHECK(render_tool::run_render_tool({"--builtin", "cube", "--width", "8", "--height", "8", "--out-triid",
                                        dir.file("ok.tri"), "--out", dir.file(name)},
                                       out, err) == render_tool::kExitRuntime);
    CHECK(err.str().find(name) != std::string::npos);
  }
  CHECK(read_bytes(victim) == std::vector<unsigned char>{'k', 'e', 'e', 'p'});
  struct stat st {};
  CHECK((::lstat(dir.file("link.png").c_str(), &st) == 0 && S_ISLNK(st.st_mode)));
  CHECK((::lstat(dir.file("fifo.png").c_str(), &st) == 0 && S_ISFIFO(st.st_mode)));
  CHECK(!exists(dir.file("ok.tri")));  // the run's other output did not appear either
  CHECK(dir.count() == 3);
}
