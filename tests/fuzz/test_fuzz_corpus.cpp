// Replays the fuzz seed corpus (tests/fuzz/corpus) through the fuzz bodies, so
// the normal test run is a regression test for every input the fuzzers were
// seeded with or crashed on. The bodies throw FuzzContractViolation on a
// broken contract (fuzz_targets.h); sanitizer builds also catch memory errors.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz/fuzz_targets.h"
#include "raster/io/obj_io.h"

namespace fs = std::filesystem;
using gr::fuzz::fuzz_obj_loader;
using gr::fuzz::fuzz_rasterize_interpolate;

namespace {

// The corpus sits next to this source file.
fs::path corpus_dir(const char* name) { return fs::path(GRADRASTER_TESTS_DIR) / "fuzz" / "corpus" / name; }

// Every file of a corpus folder, sorted by name (empty if the folder is missing).
std::vector<fs::path> corpus_files(const char* name) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(corpus_dir(name), ec))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::uint8_t> read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

template <class Body>
void replay(const char* corpus, Body body, std::size_t min_files) {
  const std::vector<fs::path> files = corpus_files(corpus);
  REQUIRE(files.size() >= min_files);
  for (const fs::path& file : files) {
    INFO("corpus file " << file.string());
    const std::vector<std::uint8_t> bytes = read_bytes(file);
    CHECK_NOTHROW(body(bytes.data(), bytes.size()));
  }
}

}  // namespace

TEST_CASE("fuzz corpus: every OBJ seed loads or fails with a gr error", "[fuzz][obj]") {
  replay("obj", fuzz_obj_loader, 12);
}

TEST_CASE("fuzz corpus: every image seed loads in [0, 1] or fails with a gr error, quickly", "[fuzz][image]") {
  replay("image", gr::fuzz::fuzz_image_reader, 12);
}

TEST_CASE("fuzz corpus: every raster seed gives finite outputs and gradients or a gr error", "[fuzz][rasterize][interpolate]") {
  replay("raster", [](const std::uint8_t* data, std::size_t size) { fuzz_rasterize_interpolate(data, size); }, 10);
}

TEST_CASE("fuzz corpus: every shape seed gives a consistent tensor or a gr error", "[fuzz][shape]") {
  replay("shapes", gr::fuzz::fuzz_shapes, 8);
}

TEST_CASE("load_obj_from_string reads OBJ text like load_obj and never touches MTL files", "[fuzz][obj]") {
  const gr::raster::Mesh mesh = gr::raster::load_obj_from_string(
      "mtllib missing.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  CHECK(mesh.num_vertices() == 4);
  CHECK(mesh.num_triangles() == 2);
  CHECK(mesh.texture_path.empty());
  CHECK_THROWS_WITH(gr::raster::load_obj_from_string("v 0 0 0\nf 1 2 3\n", "inline.obj"),
                    Catch::Contains("inline.obj") && Catch::Contains("line 2"));
}

TEST_CASE("load_obj_from_string reads a line as the line check does, or rejects it", "[fuzz][obj][errors]") {
  // Found by fuzz_obj: the line check stops at '#', tinyobjloader read a 4th
  // corner "5" and returned an out-of-range index (heap overflow before the
  // fix). The parser now gets the line without its comment: one triangle.
  const gr::raster::Mesh mesh =
      gr::raster::load_obj_from_string("v 0 0 0\nv 1 0 0\nv 2 2 0\nv 0 2 0\nf 1 2 3#4 5\n");
  CHECK(mesh.num_triangles() == 1);
  // Finite as double, infinite as float.
  CHECK_THROWS_WITH(gr::raster::load_obj_from_string("v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n"),
                    Catch::Contains("line 2"));
}
