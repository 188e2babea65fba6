// raster/io/mtl_reader.h: each MTL file an OBJ names is read once, however it is
// spelled; a missing one is a warning.
#include <catch2/catch.hpp>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "raster/io/mtl_reader.h"
#include "raster/temp_dir.h"

using gr::testing::TempDir;

TEST_CASE("MtlReader reads a file named by two spellings once and records it - a missing file is a warning",
          "[raster][io][obj][mtl]") {
  TempDir dir;
  dir.write("x.mtl", "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n");
  gr::raster::MtlReader reader("v.obj", dir.file(""), 0);
  std::vector<tinyobj::material_t> materials;
  std::map<std::string, int> ids;
  std::string warn, err;
  CHECK(reader("x.mtl", &materials, &ids, &warn, &err));
  CHECK(reader("./x.mtl", &materials, &ids, &warn, &err));
  CHECK(materials.size() == 2);
  REQUIRE(reader.files_read().size() == 1);
  CHECK(std::filesystem::equivalent(reader.files_read()[0], dir.file("x.mtl")));
  CHECK_FALSE(reader("missing.mtl", &materials, &ids, &warn, &err));
  CHECK_THAT(warn, Catch::Contains("missing.mtl") && Catch::Contains("not found"));
  CHECK(reader.files_read().size() == 1);
}
