// The tools ended mid-run by a signal (issue 30 item 6), run as real
// processes: gradraster-render stopped in the middle of writing an output
// (a file size limit raises SIGXFSZ there) and gradraster-fit stopped by
// SIGINT or SIGTERM while its staging folder exists leave no temporary, no
// staging folder and no output folder they created, and die by that signal;
// the next fit into the same folder removes a staging folder that a SIGKILL
// left behind.
#include <catch2/catch.hpp>

// The tools are built only with GRADRASTER_BUILD_EXAMPLES (not in the sanitizer job).
#if defined(GRADRASTER_RENDER_PROGRAM) && defined(GRADRASTER_FIT_PROGRAM)

#include <signal.h>

#include <filesystem>
#include <string>
#include <vector>

#include "child_process.h"
#include "raster/temp_dir.h"

using gr::testing::ChildProcess;
using gr::testing::describe_status;
using gr::testing::TempDir;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> entries(const fs::path& folder) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(folder)) names.push_back(e.path().filename().string());
  return names;
}

bool has_staging_folder(const fs::path& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return false;
  for (const std::string& name : entries(folder))
    if (name.size() > 8 && name.compare(name.size() - 8, 8, ".staging") == 0) return true;
  return false;
}

// A fit that runs until it is stopped; its outputs would go to `out`.
std::vector<std::string> endless_fit(const fs::path& out) {
  return {GRADRASTER_FIT_PROGRAM, "--out", out.string(), "--size", "16", "--views", "1", "--iterations", "1000000",
          "--subdivisions", "1", "--threads", "1"};
}

}  // namespace

TEST_CASE("gradraster-render stopped by a signal in the middle of writing leaves no temporary",
          "[examples][render][temporaries]") {
  TempDir dir;
  // 512 x 512 x 4 bytes of tri_id; the write stops at 64 KiB with SIGXFSZ.
  ChildProcess render({GRADRASTER_RENDER_PROGRAM, "--builtin", "sphere", "--width", "512", "--height", "512",
                       "--out-triid", dir.file("triid.raw")},
                      /*file_size_limit=*/1 << 16);
  const int status = render.wait(60);
  INFO(describe_status(status) << "\n" << render.output());
  CHECK((WIFSIGNALED(status) && WTERMSIG(status) == SIGXFSZ));
  CHECK(entries(dir.path()).empty());
}

TEST_CASE("gradraster-fit stopped by SIGINT or SIGTERM leaves neither its staging folder nor the folder it created",
          "[examples][fit][temporaries]") {
  for (int sig : {SIGINT, SIGTERM}) {
    CAPTURE(sig);
    TempDir dir;
    const fs::path out = dir.path() / "new" / "out";
    ChildProcess fit(endless_fit(out));
    REQUIRE(fit.wait_until([&] { return has_staging_folder(out); }, 120));
    ::kill(fit.pid(), sig);
    const int status = fit.wait(60);
    INFO(describe_status(status) << "\n" << fit.output());
    CHECK((WIFSIGNALED(status) && WTERMSIG(status) == sig));
    CHECK(entries(dir.path()).empty());
  }
}

TEST_CASE("the next gradraster-fit into a folder removes the staging folder of a fit killed by SIGKILL",
          "[examples][fit][temporaries]") {
  TempDir dir;
  const fs::path out = dir.path() / "out";
  {
    ChildProcess fit(endless_fit(out));
    REQUIRE(fit.wait_until([&] { return has_staging_folder(out); }, 120));
    ::kill(fit.pid(), SIGKILL);  // no handler runs: the staging folder stays
    REQUIRE(fit.wait(60) != -1);
  }
  REQUIRE(has_staging_folder(out));
  ChildProcess next({GRADRASTER_FIT_PROGRAM, "--out", out.string(), "--size", "16", "--views", "1", "--iterations",
                     "1", "--subdivisions", "1", "--threads", "1"});
  const int status = next.wait(120);
  INFO(describe_status(status) << "\n" << next.output());
  REQUIRE(status == 0);
  CHECK(!has_staging_folder(out));
  CHECK(fs::exists(out / "fitted.obj"));
}

#endif
