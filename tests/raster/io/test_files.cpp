// raster/io/files.h: bounded reads of regular input files, output sets that
// appear together or not at all, and short printable quotes for messages.
#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <string>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "raster/io/files.h"
#include "raster/temp_dir.h"

using namespace gr;
using namespace gr::raster;
using gr::testing::slurp;
using gr::testing::TempDir;

namespace {

}  // namespace

TEST_CASE("read_input_file reads a regular file, also through a symlink", "[raster][io][files]") {
  TempDir dir;
  const std::string path = dir.write("a.txt", std::string("x\0y", 3));
  CHECK(read_input_file(path, "test") == std::string("x\0y", 3));
  REQUIRE(::symlink(path.c_str(), dir.file("link.txt").c_str()) == 0);
  CHECK(read_input_file(dir.file("link.txt"), "test") == std::string("x\0y", 3));
  CHECK(read_input_file(dir.write("empty.txt", ""), "test").empty());
}

TEST_CASE("read_input_file refuses folders, FIFOs and devices without blocking, naming the kind", "[raster][io][files]") {
  TempDir dir;
  REQUIRE(::mkfifo(dir.file("fifo").c_str(), 0600) == 0);
  CHECK_THROWS_WITH(read_input_file(dir.file("fifo"), "reader('fifo')"),
                    Catch::StartsWith("reader('fifo')") && Catch::Contains("FIFO"));
  CHECK_THROWS_WITH(read_input_file("/dev/zero", "r"), Catch::Contains("character device"));
  CHECK_THROWS_WITH(read_input_file(dir.path().string(), "r"), Catch::Contains("is a directory"));
  CHECK_THROWS_WITH(read_input_file(dir.file("absent"), "r"), Catch::Contains("No such file"));
}

TEST_CASE("read_input_file stops at its size limit, also for files whose size reads 0", "[raster][io][files]") {
  TempDir dir;
  const std::string path = dir.write("big.txt", std::string(1000, 'a'));
  CHECK(read_input_file(path, "r", 1000).size() == 1000);
  CHECK_THROWS_AS(read_input_file(path, "r", 999), IOError);
  // /proc files are regular files whose size reads 0.
  CHECK_THROWS_WITH(read_input_file("/proc/self/maps", "r", 10), Catch::Contains("input limit of 10 bytes"));
  CHECK(!read_input_file("/proc/self/maps", "r").empty());
}

TEST_CASE("read_input_file checks the size against the memory budget before reading", "[raster][io][files]") {
  TempDir dir;
  const std::string path = dir.write("big.txt", std::string(1 << 20, 'a'));
  set_memory_limit(memory_in_use() + 1000);
  CHECK_THROWS_AS(read_input_file(path, "r"), MemoryError);
  set_memory_limit(0);
  CHECK(read_input_file(path, "r").size() == std::size_t(1) << 20);
}

TEST_CASE("an output set renames its files only at commit, and removes them if not committed", "[raster][io][files]") {
  TempDir dir;
  {
    OutputSet outputs;
    outputs.stage(dir.file("a.bin"), "aa", 2);
    outputs.stage(dir.file("b.bin"), "bbb", 3);
    CHECK(::access(dir.file("a.bin").c_str(), F_OK) != 0);
    CHECK(dir.count() == 2);  // the two temporaries
    outputs.commit();
  }
  CHECK(slurp(dir.file("a.bin")) == "aa");
  CHECK(slurp(dir.file("b.bin")) == "bbb");
  CHECK(dir.count() == 2);
  {
    OutputSet outputs;
    outputs.stage(dir.file("a.bin"), "new", 3);
    CHECK_THROWS_AS(outputs.stage(dir.file("no/folder/c.bin"), "c", 1), IOError);
  }  // not committed: nothing replaced, no temporary left
  CHECK(slurp(dir.file("a.bin")) == "aa");
  CHECK(dir.count() == 2);
}

TEST_CASE("an output refuses a symlink, FIFO or folder target and leaves it as it was", "[raster][io][files]") {
  TempDir dir;
  const std::string victim = dir.write("victim.txt", "keep");
  REQUIRE(::symlink(victim.c_str(), dir.file("link").c_str()) == 0);
  REQUIRE(::mkfifo(dir.file("fifo").c_str(), 0600) == 0);
  REQUIRE(::mkdir(dir.file("folder").c_str(), 0700) == 0);
  for (const char* name : {"link", "fifo", "folder"}) {
    INFO(name);
    OutputSet outputs;
    CHECK_THROWS_WITH(outputs.stage(dir.file(name), "x", 1),
                      Catch::Contains(dir.file(name)) && Catch::Contains("refusing to replace"));
  }
  struct stat st {};
  REQUIRE(::lstat(dir.file("link").c_str(), &st) == 0);
  CHECK(S_ISLNK(st.st_mode));
  REQUIRE(::lstat(dir.file("fifo").c_str(), &st) == 0);
  CHECK(S_ISFIFO(st.st_mode));
  CHECK(slurp(victim) == "keep");
  CHECK(dir.count() == 4);
}

TEST_CASE("an output with a 254-character name is written (the temporary's name stays short)", "[raster][io][files]") {
  TempDir dir;
  const std::string path = dir.file(std::string(250, 'n') + ".bin");
  OutputSet outputs;
  outputs.stage(path, "ok", 2);
  outputs.commit();
  CHECK(slurp(path) == "ok");
}

TEST_CASE("quote_for_message shows at most 40 bytes and escapes control bytes", "[raster][io][files]") {
  CHECK(quote_for_message("abc") == "'abc'");
  CHECK(quote_for_message(std::string("a\0b\n", 4)) == "'a\\x00b\\x0a'");
  const std::string q = quote_for_message(std::string(1 << 20, 'z'));
  CHECK(q == "'" + std::string(40, 'z') + "...'");
}
