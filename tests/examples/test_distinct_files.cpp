// examples/common/distinct_files.h: an output that is an input or another
// output is refused, however the paths are spelled: relative or absolute,
// with ./ and ../, through a symlink (to the file or to its folder), a hard
// link, or two names of one device.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "examples/common/cli_args.h"
#include "examples/common/distinct_files.h"
#include "raster/temp_dir.h"

using gr::cli::check_distinct_files;
using gr::cli::same_file;
using gr::cli::UsageError;
using gr::testing::TempDir;
namespace fs = std::filesystem;

namespace {

// Runs `body` with the working directory set to `dir`, restoring it after.
template <class Body>
void inside(const fs::path& dir, Body body) {
  const fs::path before = fs::current_path();
  fs::current_path(dir);
  try {
    body();
  } catch (...) {
    fs::current_path(before);
    throw;
  }
  fs::current_path(before);
}

}  // namespace

TEST_CASE("distinct files: one file spelled many ways is the same file", "[examples][distinct_files]") {
  TempDir dir;
  const std::string v = dir.write("v.obj", "v 0 0 0\n");
  fs::create_directory(dir.file("a"));
  REQUIRE(::symlink(v.c_str(), dir.file("link.obj").c_str()) == 0);
  REQUIRE(::symlink(dir.path().c_str(), dir.file("a/up").c_str()) == 0);
  REQUIRE(::link(v.c_str(), dir.file("hard.obj").c_str()) == 0);
  inside(dir.path(), [&] {
    for (const std::string& other : {std::string("v.obj"), std::string("./v.obj"), std::string("a/../v.obj"), v,
                                     std::string("link.obj"), std::string("a/up/v.obj"), std::string("hard.obj")}) {
      INFO(other);
      CHECK(same_file("v.obj", other));
    }
    // Files that do not exist yet compare by where they would be.
    CHECK(same_file("new.png", "./a/../new.png"));
    CHECK(same_file("new.png", dir.file("new.png")));
    CHECK(same_file("a/up/new.png", "new.png"));
    CHECK(!same_file("new.png", "a/new.png"));
    CHECK(!same_file("v.obj", "new.png"));
  });
  CHECK(same_file("/dev/stdout", "/dev/fd/1"));
}

TEST_CASE("distinct files: an output that is an input is refused, naming both flags", "[examples][distinct_files]") {
  TempDir dir;
  const std::string v = dir.write("v.obj", "v 0 0 0\n");
  CHECK_THROWS_WITH(check_distinct_files({{"--mesh", v}}, {{"--out", dir.file("a.png")}, {"--out-depth", v}}),
                    Catch::StartsWith("--out-depth '") && Catch::Contains("is the same file as --mesh") &&
                        Catch::Contains("refusing to overwrite an input"));
  CHECK_THROWS_AS(check_distinct_files({{"--mesh", v}}, {{"--out", dir.file("./v.obj")}}), UsageError);
  CHECK_NOTHROW(check_distinct_files({{"--mesh", v}, {"--texture", ""}}, {{"--out", dir.file("a.png")}, {"--out-depth", ""}}));
  CHECK(dir.count() == 1);  // nothing written
}

TEST_CASE("distinct files: two outputs sharing a file are refused", "[examples][distinct_files]") {
  TempDir dir;
  CHECK_THROWS_WITH(check_distinct_files({}, {{"--out", dir.file("x")}, {"--out-triid", dir.file("y")},
                                              {"--out-depth", dir.file("x")}}),
                    Catch::StartsWith("--out-depth '") && Catch::Contains("is the same file as --out '") &&
                        Catch::Contains("two outputs cannot share a file"));
  CHECK_THROWS_AS(check_distinct_files({}, {{"--out", "/dev/stdout"}, {"--out-depth", "/dev/fd/1"}}), UsageError);
  CHECK(dir.count() == 0);
}
