// Tests of raster/mesh.h and raster/io/obj_io.h: OBJ loading (triangulation,
// welding, materials), its error handling on malformed files, save/load round
// trips, and Mesh::validate.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/base/storage.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/heap_peak.h"
#include "raster/temp_dir.h"

using namespace gr;
using namespace gr::raster;
using gr::testing::TempDir;

namespace {

const char* kSquareVerts = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

std::vector<int> tri_list(const Mesh& m) {
  std::vector<int> out;
  for (double x : m.triangles.to_vector()) out.push_back(static_cast<int>(x));
  return out;
}

// Twice the signed area of triangle t projected on the xy plane.
double signed_area2_xy(const Mesh& m, std::int64_t t) {
  const float* p = m.positions.data<float>();
  const std::int32_t* tri = m.triangles.data<std::int32_t>();
  const float* a = p + 3 * tri[3 * t];
  const float* b = p + 3 * tri[3 * t + 1];
  const float* c = p + 3 * tri[3 * t + 2];
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

// Requires load_obj to throw IOError whose message contains every fragment.
void require_load_error(const std::string& path, const std::vector<std::string>& fragments) {
  try {
    load_obj(path);
    FAIL("load_obj did not throw for " << path);
  } catch (const IOError& e) {
    const std::string msg = e.what();
    INFO(msg);
    for (const std::string& f : fragments) CHECK(msg.find(f) != std::string::npos);
  }
}

bool contains(const std::vector<std::string>& lines, const std::string& fragment) {
  for (const std::string& l : lines)
    if (l.find(fragment) != std::string::npos) return true;
  return false;
}

}  // namespace

TEST_CASE("load_obj: triangles keep file order and vertices follow the v lines", "[raster][io][obj]") {
  TempDir dir;
  const std::string path = dir.write("tris.obj", std::string(kSquareVerts) +
                                                     "# comment\n"
                                                     "f 3 4 1\n"
                                                     "f 1 2 3\n");
  Mesh m = load_obj(path);
  CHECK(m.warnings.empty());
  REQUIRE(m.num_vertices() == 4);
  REQUIRE(m.num_triangles() == 2);
  CHECK(tri_list(m) == std::vector<int>{2, 3, 0, 0, 1, 2});
  CHECK(m.positions.to_vector() == std::vector<double>{0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  CHECK_FALSE(m.has_normals());
  CHECK_FALSE(m.has_uvs());
  CHECK(m.texture_path.empty());
}

TEST_CASE("load_obj: a quad and a pentagon are fanned into 2 and 3 triangles in place", "[raster][io][obj]") {
  TempDir dir;
  const std::string path = dir.write("poly.obj", std::string(kSquareVerts) +
                                                     "v 3 0 0\nv 4 0 0\nv 4.5 1 0\nv 3.5 2 0\nv 2.5 1 0\n"
                                                     "f 1 2 3\n"          // triangle 0
                                                     "f 1 2 3 4\n"        // triangles 1, 2
                                                     "f 5 6 7 8 9\n"      // triangles 3, 4, 5
                                                     "f -4 -3 -1\n");     // triangle 6: 6 7 9
  Mesh m = load_obj(path);
  REQUIRE(m.num_triangles() == 7);
  CHECK(tri_list(m) == std::vector<int>{0, 1, 2, 0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 4, 7, 8, 5, 6, 8});
  // Counter-clockwise polygons stay counter-clockwise.
  for (std::int64_t t = 0; t < m.num_triangles(); ++t) CHECK(signed_area2_xy(m, t) > 0);
}

TEST_CASE("load_obj: concave polygons are ear-clipped without overlap whatever corner comes first", "[raster][io][obj]") {
  // A U shape (area 5) away from the origin; tinyobjloader 2.0.0rc10's own
  // triangulation produces overlapping triangles for some rotations of it.
  const double U[8][2] = {{0, 0}, {3, 0}, {3, 2}, {2, 2}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  TempDir dir;
  for (int rot = 0; rot < 8; ++rot) {
    for (int mirror = 0; mirror < 2; ++mirror) {
      std::ostringstream obj;
      for (int i = 0; i < 8; ++i) {
        const int k = mirror ? (rot - i + 16) % 8 : (rot + i) % 8;  // mirror: clockwise
        obj << "v " << U[k][0] + 5 << ' ' << U[k][1] + 5 << " 1\n";
      }
      obj << "f 1 2 3 4 5 6 7 8\n";
      Mesh m = load_obj(dir.write("u.obj", obj.str()));
      INFO("rotation " << rot << (mirror ? " clockwise" : " counter-clockwise"));
      REQUIRE(m.num_triangles() == 6);
      double total = 0;
      for (std::int64_t t = 0; t < 6; ++t) {
        const double a = signed_area2_xy(m, t) / 2;
        CHECK((mirror ? -a : a) > 0);  // every triangle keeps the polygon's winding
        total += std::fabs(a);
      }
      CHECK(total == Approx(5.0));  // no overlap, no gap
    }
  }
}

TEST_CASE("load_obj: separate v/vt/vn indices are welded into one index per distinct triple", "[raster][io][obj]") {
  TempDir dir;
  // Two triangles sharing the edge 1-3 with different normals at it: 6 distinct
  // triples, 4 positions.
  const std::string path = dir.write("weld.obj", std::string(kSquareVerts) +
                                                     "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                                     "vn 0 0 1\nvn 0 0.6 0.8\n"
                                                     "f 1/1/1 2/2/1 3/3/1\n"
                                                     "f 1/1/2 3/3/2 4/4/2\n"
                                                     "f 3/3/1 1/1/1 2/2/1\n");
  Mesh m = load_obj(path);
  REQUIRE(m.num_vertices() == 6);
  REQUIRE(m.has_normals());
  REQUIRE(m.has_uvs());
  // Order: by position index, then texcoord, then normal.
  CHECK(tri_list(m) == std::vector<int>{0, 2, 3, 1, 4, 5, 3, 0, 2});
  CHECK(m.positions.to_vector() ==
        std::vector<double>{0, 0, 0, 0, 0, 0, 1, 0, 0, 1, 1, 0, 1, 1, 0, 0, 1, 0});
  CHECK(m.normals.at({0, 2}) == Approx(1.0));
  CHECK(m.normals.at({1, 1}) == Approx(0.6));
  CHECK(m.uvs.to_vector() == std::vector<double>{0, 0, 0, 0, 1, 0, 1, 1, 1, 1, 0, 1});
}

TEST_CASE("load_obj: partial normals are dropped and unused vertices reported as warnings", "[raster][io][obj]") {
  TempDir dir;
  const std::string path = dir.write("partial.obj", std::string(kSquareVerts) +
                                                        "v 9 9 9\n"
                                                        "vn 0 0 1\n"
                                                        "f 1//1 2//1 3//1\n"
                                                        "f 1 3 4\n");
  Mesh m = load_obj(path);
  CHECK(m.num_vertices() == 4);
  CHECK_FALSE(m.has_normals());
  CHECK(contains(m.warnings, "lack normals"));
  CHECK(contains(m.warnings, "1 vertices are used by no face"));
}

TEST_CASE("load_obj: malformed lines throw IOError naming the file and the line", "[raster][io][obj][errors]") {
  TempDir dir;
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  struct Case {
    const char* name;
    std::string text;
    std::string fragment;
  };
  const std::vector<Case> cases = {
      {"bad number", "v 0 0 0\nv 1 0 abc\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"truncated vertex", tri + "v 1 1\nf 1 2 4\n", "line 4"},
      {"truncated normal", tri + "vn 0 1\nf 1//1 2//1 3//1\n", "line 4"},
      {"bad texcoord", tri + "vt 0.5 x\nf 1/1 2/1 3/1\n", "line 4"},
      {"non-finite vertex", "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"overflowing vertex", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", "line 2"},
      {"face beyond the vertices", tri + "f 1 2 99\n", "line 4"},
      {"negative index beyond the start", tri + "f -1 -2 -5\n", "line 4"},
      {"missing texcoord", tri + "f 1/1 2/1 3/1\n", "texcoord"},
      {"missing normal", tri + "vt 0 0\nf 1/1/1 2/1/1 3/1/1\n", "normal"},
      {"face with two corners", tri + "f 1 2\n", "line 4"},
      {"truncated face line", tri + "f 1 2 3\nf 1 2", "line 5"},
      {"zero index", tri + "f 0 1 2\n", "index 0"},
      {"fractional index", tri + "f 1.5 2 3\n", "line 4"},
      {"garbage index", tri + "f 1 x 3\n", "line 4"},
      {"dangling slash", tri + "f 1/ 2 3\n", "line 4"},
  };
  for (const Case& c : cases) {
    INFO(c.name);
    const std::string path = dir.write("bad.obj", c.text);
    require_load_error(path, {path, c.fragment});
  }
}

TEST_CASE("load_obj: missing files, directories and files without triangles throw IOError", "[raster][io][obj][errors]") {
  TempDir dir;
  require_load_error(dir.file("nope.obj"), {"nope.obj", "cannot open"});
  require_load_error(dir.path().string(), {"directory"});
  require_load_error(dir.write("empty.obj", ""), {"empty.obj", "no triangles"});
  require_load_error(dir.write("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), {"no triangles"});
  require_load_error(dir.write("lines.obj", "v 0 0 0\nv 1 0 0\nl 1 2\n"), {"no triangles"});
}

TEST_CASE("load_obj: the MTL diffuse map is resolved next to the OBJ file", "[raster][io][obj][mtl]") {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "tex");
  write_png(dir.file("tex/checker.png"), Tensor::full({2, 2, 3}, 0.5));
  dir.write("m.mtl", "newmtl red\nKd 1 0 0\n\nnewmtl checker\nKd 1 1 1\nmap_Kd tex/checker.png\n");
  const std::string path = dir.write("m.obj", std::string("mtllib m.mtl\n") + kSquareVerts +
                                                  "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                                  "usemtl red\nf 1/1 2/2 3/3\n"
                                                  "usemtl checker\nf 1/1 3/3 4/4\n");
  Mesh m = load_obj(path);
  CHECK(m.warnings.empty());
  CHECK(m.num_triangles() == 2);
  CHECK(std::filesystem::equivalent(m.texture_path, dir.file("tex/checker.png")));
  CHECK(tri_list(m) == std::vector<int>{0, 1, 2, 0, 2, 3});  // usemtl does not reorder faces
}

TEST_CASE("load_obj: a missing MTL file or texture is a warning and leaves texture_path empty", "[raster][io][obj][mtl]") {
  TempDir dir;
  const std::string body = std::string(kSquareVerts) + "usemtl checker\nf 1 2 3\n";
  SECTION("missing MTL file") {
    Mesh m = load_obj(dir.write("a.obj", "mtllib gone.mtl\n" + body));
    CHECK(m.num_triangles() == 1);
    CHECK(m.texture_path.empty());
    CHECK(contains(m.warnings, "gone.mtl"));
  }
  SECTION("missing texture") {
    dir.write("b.mtl", "newmtl checker\nmap_Kd missing.png\n");
    Mesh m = load_obj(dir.write("b.obj", "mtllib b.mtl\n" + body));
    CHECK(m.texture_path.empty());
    CHECK(contains(m.warnings, "missing.png"));
  }
}

TEST_CASE("save_obj then load_obj gives back the same mesh", "[raster][io][obj]") {
  TempDir dir;
  SECTION("positions, normals and uvs (torus)") {
    Mesh a = make_torus(12, 7, 1.0f, 0.3f);
    save_obj(dir.file("t.obj"), a);
    Mesh b = load_obj(dir.file("t.obj"));
    CHECK(b.warnings.empty());
    CHECK(b.positions.to_vector() == a.positions.to_vector());  // bit-exact floats
    CHECK(b.normals.to_vector() == a.normals.to_vector());
    CHECK(b.uvs.to_vector() == a.uvs.to_vector());
    CHECK(b.triangles.to_vector() == a.triangles.to_vector());
  }
  SECTION("positions only") {
    Mesh a = make_icosphere(2);
    a.normals = Tensor();
    a.uvs = Tensor();
    save_obj(dir.file("i.obj"), a);
    Mesh b = load_obj(dir.file("i.obj"));
    CHECK_FALSE(b.has_normals());
    CHECK_FALSE(b.has_uvs());
    CHECK(b.positions.to_vector() == a.positions.to_vector());
    CHECK(b.triangles.to_vector() == a.triangles.to_vector());
  }
  SECTION("with a texture: an MTL file is written beside the OBJ") {
    write_png(dir.file("skin.png"), Tensor::zeros({1, 1, 3}));
    Mesh a = make_cube();
    a.texture_path = dir.file("skin.png");
    std::filesystem::create_directories(dir.path() / "out");
    save_obj(dir.file("out/c.obj"), a);
    CHECK(std::filesystem::exists(dir.file("out/c.mtl")));
    Mesh b = load_obj(dir.file("out/c.obj"));
    CHECK(b.warnings.empty());
    CHECK(std::filesystem::equivalent(b.texture_path, a.texture_path));
    CHECK(b.triangles.to_vector() == a.triangles.to_vector());
  }
}

TEST_CASE("save_obj: a failed save leaves no file and no temporary behind", "[raster][io][obj][errors]") {
  TempDir dir;
  Mesh m = make_cube();
  CHECK_THROWS_AS(save_obj(dir.file("no/such/dir/c.obj"), m), IOError);
  // An invalid mesh is rejected before anything is written; an old file survives.
  const std::string path = dir.write("keep.obj", "old contents");
  m.triangles.data<std::int32_t>()[5] = 99;
  CHECK_THROWS_AS(save_obj(path, m), IndexError);
  std::ifstream in(path);
  std::string contents((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(contents == "old contents");
  CHECK(dir.count() == 1);
}

TEST_CASE("Mesh::validate names the field that is wrong", "[raster][io][mesh][errors]") {
  Mesh good = make_plane(2, 2);
  CHECK_NOTHROW(good.validate("test"));
  SECTION("positions of the wrong shape") {
    Mesh m = good;
    m.positions = Tensor::zeros({9, 2});
    CHECK_THROWS_AS(m.validate("test"), ShapeError);
  }
  SECTION("float64 positions") {
    Mesh m = good;
    m.positions = Tensor::zeros({9, 3}, DType::Float64);
    CHECK_THROWS_AS(m.validate("test"), DTypeError);
  }
  SECTION("float triangles") {
    Mesh m = good;
    m.triangles = Tensor::zeros({8, 3});
    CHECK_THROWS_AS(m.validate("test"), DTypeError);
  }
  SECTION("a NaN position") {
    Mesh m = good;
    m.positions = good.positions.copy();
    m.positions.data<float>()[4] = std::nanf("");
    CHECK_THROWS_WITH(m.validate("test"), Catch::Contains("positions") && Catch::Contains("row 1"));
  }
  SECTION("normals with another vertex count") {
    Mesh m = good;
    m.normals = Tensor::zeros({8, 3});
    CHECK_THROWS_AS(m.validate("test"), ShapeError);
  }
  SECTION("a negative or too large index") {
    Mesh m = good;
    m.triangles = good.triangles.copy();
    m.triangles.data<std::int32_t>()[7] = 9;
    CHECK_THROWS_AS(m.validate("test"), IndexError);
    m.triangles.data<std::int32_t>()[7] = -1;
    CHECK_THROWS_WITH(m.validate("test"), Catch::Contains("triangles[2]"));
  }
}

TEST_CASE("load_obj: a 255-corner polygon loads, 256 corners name the limit and the line", "[raster][io][obj][errors]") {
  auto polygon = [](int n) {
    std::ostringstream s;
    s << "# polygon\n";
    for (int i = 0; i < n; ++i)
      s << "v " << std::cos(6.283185307179586 * i / n) << " " << std::sin(6.283185307179586 * i / n) << " 0\n";
    s << "f";
    for (int i = 1; i <= n; ++i) s << " " << i;
    s << "\n";
    return s.str();
  };
  CHECK(gr::raster::load_obj_from_string(polygon(255)).num_triangles() == 253);
  CHECK_THROWS_WITH(gr::raster::load_obj_from_string(polygon(256), "big.obj"),
                    Catch::Contains("big.obj") && Catch::Contains("line 258") &&
                        Catch::Contains("256 corners") && Catch::Contains("at most 255"));
}

TEST_CASE("load_obj: the texture named by the MTL file must be a regular file", "[raster][io][obj][mtl][errors]") {
  TempDir dir;
  dir.write("m.mtl", "newmtl a\nmap_Kd pipe.png\n");
  REQUIRE(::mkfifo(dir.file("pipe.png").c_str(), 0600) == 0);
  const std::string obj = dir.write("m.obj", "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n");
  CHECK_THROWS_WITH(load_obj(obj), Catch::Contains("pipe.png") && Catch::Contains("not a regular file"));
}

TEST_CASE("load_obj: text whose parsing could exceed the memory budget is refused before parsing", "[raster][io][obj][memory]") {
  std::string text;
  for (int i = 0; i < 20000; ++i) text += "v 0 0 0\n";
  text += "f 1 2 3\n";
  gr::set_memory_limit(gr::memory_in_use() + 100000);
  CHECK_THROWS_WITH(load_obj_from_string(text, "big.obj"), Catch::Contains("load_obj('big.obj') of 160008 bytes"));
  gr::set_memory_limit(0);
  CHECK(load_obj_from_string(text, "big.obj").num_triangles() == 1);
}

namespace {

// An OBJ of `faces` faces of 255 corners with one-digit indices ("f 1 2 3 ... "),
// the cheapest text per corner: 512 bytes a face.
std::string many_corner_faces(int faces) {
  std::string text;
  for (int i = 0; i < 9; ++i) text += "v " + std::to_string(i % 3) + " " + std::to_string(i / 3) + " 0\n";
  std::string face = "f";
  for (int k = 0; k < 255; ++k) face += " " + std::to_string(1 + k % 9);
  face += "\n";
  for (int f = 0; f < faces; ++f) text += face;
  return text;
}

std::size_t slurp_size(const std::string& path) { return gr::testing::slurp(path).size(); }

// The most bytes load_obj held at once, on the heap and in tensor buffers.
std::size_t peak_bytes_of_load(const std::string& path) {
  gr::reset_storage_peak();
  const auto tensors_before = gr::storage_stats().live_bytes;
  gr::testing::HeapPeak heap;
  const Mesh mesh = load_obj(path);
  REQUIRE(mesh.num_triangles() > 0);
  return heap.bytes() + static_cast<std::size_t>(gr::storage_stats().peak_live_bytes - tensors_before);
}

// Restores the default memory limit when a test ends, also by an exception.
struct MemoryLimit {
  explicit MemoryLimit(std::size_t bytes_free) { gr::set_memory_limit(gr::memory_in_use() + bytes_free); }
  ~MemoryLimit() { gr::set_memory_limit(0); }
};

}  // namespace

TEST_CASE("load_obj: faces of many corners that need more than the memory budget are refused, a normal OBJ still loads",
          "[raster][io][obj][memory]") {
  TempDir dir;
  const std::string text = many_corner_faces(1000);
  const std::string path = dir.write("faces.obj", text);
  // Measured: the load holds about 50 bytes per byte of this text at its peak
  // (heap and tensors); the former estimate, 16 bytes per byte, let it through.
  std::vector<std::size_t> budgets = {16 * text.size() + 1};
  if (gr::testing::HeapPeak::counting()) {
    const std::size_t peak = peak_bytes_of_load(path);
    INFO("peak " << peak << " bytes for " << text.size() << " bytes of OBJ");
    REQUIRE(peak > 16 * text.size());
    budgets.push_back(peak - 1);
  }
  // The estimate is an upper bound: any budget below the peak refuses the file before parsing.
  for (const std::size_t budget : budgets) {
    MemoryLimit limit(budget);
    CHECK_THROWS_WITH(load_obj(path), Catch::Contains("faces.obj") && Catch::Contains("1000 faces of 255000 corners") &&
                                          Catch::Contains("memory limit"));
    CHECK_THROWS_AS(load_obj(path), MemoryError);
  }
  // A normal mesh (a sphere written by save_obj) loads within a budget of a
  // few times its own measured peak (about 6 bytes per byte of its text; the
  // estimate says 8).
  Mesh sphere = make_uv_sphere(64, 32);
  save_obj(dir.file("sphere.obj"), sphere);
  const std::size_t sphere_bytes = slurp_size(dir.file("sphere.obj"));
  const std::size_t sphere_peak =
      gr::testing::HeapPeak::counting() ? peak_bytes_of_load(dir.file("sphere.obj")) : 10 * sphere_bytes;
  MemoryLimit limit(3 * sphere_peak);
  CHECK(load_obj(dir.file("sphere.obj")).num_triangles() == sphere.num_triangles());
}

TEST_CASE("load_obj: an MTL file named by several mtllib lines is parsed once, whatever the spelling",
          "[raster][io][obj][mtl][memory]") {
  if (!gr::testing::HeapPeak::counting()) return;  // TSan build: nothing to measure with
  TempDir dir;
  std::string mtl;
  for (int i = 0; i < 2000; ++i) mtl += "newmtl m" + std::to_string(i) + "\nKd 1 1 1\n";
  mtl += "newmtl last\nmap_Kd tex.png\n";
  dir.write("x.mtl", mtl);
  write_png(dir.file("tex.png"), Tensor::full({2, 2, 3}, 0.5));
  REQUIRE(::symlink("x.mtl", dir.file("alias.mtl").c_str()) == 0);
  const std::string tri = "usemtl last\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
  dir.write("once.obj", "mtllib x.mtl\n" + tri);
  std::string lines;
  for (const char* name : {"x.mtl", "./x.mtl", "././x.mtl", "alias.mtl"})
    for (int k = 0; k < 5; ++k) lines += std::string("mtllib ") + name + "\n";
  dir.write("twenty.obj", lines + tri);
  const std::size_t once = peak_bytes_of_load(dir.file("once.obj"));
  const std::size_t twenty = peak_bytes_of_load(dir.file("twenty.obj"));
  INFO("peak with one mtllib line " << once << " bytes, with twenty " << twenty);
  CHECK(twenty < once + once / 4);  // each parse held every material again (20 times the memory)
  const Mesh mesh = load_obj(dir.file("twenty.obj"));
  CHECK(mesh.texture_path == dir.file("tex.png"));
}

TEST_CASE("load_obj: the mesh names each MTL file it read once, as resolved", "[raster][io][obj][mtl]") {
  TempDir dir;
  dir.write("x.mtl", "newmtl m\nKd 1 1 1\n");
  dir.write("v.obj", "mtllib x.mtl\nmtllib ./x.mtl\nmtllib missing.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const Mesh mesh = load_obj(dir.file("v.obj"));
  REQUIRE(mesh.material_files.size() == 1);
  CHECK(std::filesystem::equivalent(mesh.material_files[0], dir.file("x.mtl")));
  CHECK(load_obj_from_string("mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").material_files.empty());
}

TEST_CASE("load_obj: an MTL file too large for the memory budget is refused naming it", "[raster][io][obj][mtl][memory]") {
  TempDir dir;
  std::string mtl;
  for (int i = 0; i < 5000; ++i) mtl += "newmtl m" + std::to_string(i) + "\n";
  dir.write("big.mtl", mtl);
  const std::string obj = dir.write("small.obj", "mtllib big.mtl\nusemtl m1\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  // 5000 materials hold about 15 MB in the parser; the OBJ itself needs less than 1 MiB.
  MemoryLimit limit(std::size_t(2) << 20);
  CHECK_THROWS_WITH(load_obj(obj), Catch::Contains("small.obj") && Catch::Contains("MTL file") &&
                                       Catch::Contains("big.mtl") && Catch::Contains("5000 materials") &&
                                       Catch::Contains("memory limit"));
  CHECK_THROWS_AS(load_obj(obj), MemoryError);
}

TEST_CASE("load_obj: lines the loader does not read cost nothing, and warnings stay few", "[raster][io][obj][memory]") {
  TempDir dir;
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  // A tag line of 20 bytes made tinyobjloader allocate 320 KB (8192 ints,
  // floats and strings), and every group copied all tags again.
  std::string tags = tri;
  for (int i = 0; i < 20; ++i) tags += "t crease 8192/8192/8192\ng group" + std::to_string(i) + "\nf 1 2 3\n";
  const std::string tag_file = dir.write("tags.obj", tags);
  if (gr::testing::HeapPeak::counting()) CHECK(peak_bytes_of_load(tag_file) < (std::size_t(1) << 20));
  // One warning per unknown material, each repeating the path: at most 20 kept.
  std::string usemtl = tri;
  for (int i = 0; i < 1000; ++i) usemtl += "usemtl missing" + std::to_string(i) + "\nf 1 2 3\n";
  const Mesh mesh = load_obj(dir.write("materials.obj", usemtl));
  CHECK(mesh.num_triangles() == 1001);
  CHECK(mesh.warnings.size() <= 22);
  CHECK(contains(mesh.warnings, "more warnings"));
}
