// gradraster-ssr driven in-process: the same flag handling as the other tools
// (--help, whole numbers, no stray arguments), its two PNGs written together,
// and its memory estimate checked before rendering.
#include <catch2/catch.hpp>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "autodiff/base/memory.h"
#include "examples/common/output_folder.h"
#include "examples/ssr/ssr_tool.h"
#include "raster/io/image_io.h"
#include "raster/temp_dir.h"

using gr::ssr_tool::run_ssr_tool;
using gr::testing::TempDir;

namespace {

struct Run {
  int code = -1;
  std::string out, err;
};

Run ssr(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  Run r;
  r.code = run_ssr_tool(args, out, err);
  r.out = out.str();
  r.err = err.str();
  return r;
}

}  // namespace

TEST_CASE("ssr tool: writes both images of the requested size into --out", "[examples][ssr]") {
  TempDir dir;
  const std::string out = dir.file("new/folder");
  const Run r = ssr({"--out", out, "--width", "24", "--height", "16"});
  INFO(r.err);
  REQUIRE(r.code == 0);
  const gr::Tensor image = gr::raster::read_image(out + "/ssr_example.png");
  CHECK(image.size(0) == 16);
  CHECK(image.size(1) == 3 * 24);
  CHECK(std::filesystem::exists(out + "/ssr_example_viewspace.png"));
  CHECK(r.out.find("DDA tracer") != std::string::npos);
}

TEST_CASE("ssr tool: --help prints usage, and bad numbers or stray arguments are usage errors naming them",
          "[examples][ssr]") {
  TempDir dir;
  const Run help = ssr({"--help"});
  CHECK(help.code == 0);
  CHECK(help.out.find("Usage: gradraster-ssr") != std::string::npos);
  CHECK(!std::filesystem::exists("--help"));
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--width", "64abc"}, "--width"},
      {{"--height", "7"}, "--height"},
      {{"--out", dir.file("x"), "extra"}, "extra"},
      {{"positional"}, "positional"},
      {{"--width", "64", "--width", "64"}, "given more than once"},
      {{"--size", "64"}, "--size"},
  };
  for (const auto& [args, names] : cases) {
    const Run r = ssr(args);
    INFO(r.err);
    CHECK(r.code == 2);
    CHECK(r.err.find(names) != std::string::npos);
  }
  CHECK(dir.count() == 0);
}

TEST_CASE("ssr tool: a request over the memory budget or an unwritable output leaves no file and no folder",
          "[examples][ssr][memory]") {
  TempDir dir;
  gr::set_memory_limit(gr::memory_in_use() + (std::size_t(1) << 20));
  const Run big = ssr({"--out", dir.file("big"), "--width", "4096", "--height", "4096"});
  gr::set_memory_limit(0);
  CHECK(big.code == 1);
  CHECK(big.err.find("gradraster-ssr 4096x4096 needs 5120 MiB") != std::string::npos);
  // The second image's target is a folder: the first image does not appear, the new folder is removed.
  std::filesystem::create_directories(dir.file("out/ssr_example_viewspace.png"));
  const Run blocked = ssr({"--out", dir.file("out"), "--width", "16", "--height", "16"});
  CHECK(blocked.code == 1);
  CHECK(blocked.err.find("ssr_example_viewspace.png") != std::string::npos);
  CHECK(!std::filesystem::exists(dir.file("out/ssr_example.png")));
  CHECK(dir.count() == 1);  // only "out": the memory-refused run made no folder
}

TEST_CASE("an output folder created for a run that fails is removed with its new parents", "[examples][ssr]") {
  TempDir dir;
  {
    gr::cli::OutputFolder folder(dir.file("a/b/c"));
    folder.create();
    CHECK(std::filesystem::is_directory(dir.file("a/b/c")));
  }
  CHECK(dir.count() == 0);
  {
    gr::cli::OutputFolder folder(dir.file("kept"));
    folder.create();
    folder.keep();
  }
  CHECK(std::filesystem::is_directory(dir.file("kept")));
}
