// raster/temporaries.h: a writer ended by SIGINT or SIGTERM in the middle of
// an output set leaves no temporary and still dies by that signal; what a
// killed process left is removed by the next write into the folder, and only
// that (exact names, dead processes of this host).
#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "child_process.h"
#include "raster/io/files.h"
#include "raster/temp_dir.h"
#include "raster/temporaries.h"

using namespace gr::raster;
using gr::testing::ChildProcess;
using gr::testing::describe_status;
using gr::testing::TempDir;
namespace fs = std::filesystem;

namespace {

// Names in `dir`, sorted.
std::vector<std::string> entries(const TempDir& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir.path())) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// The pid of a process that has ended (and been reaped).
pid_t dead_pid() {
  ChildProcess child({"/bin/true"});
  REQUIRE(child.wait(10) == 0);
  return child.pid();
}

// `name` (one of ours, ".gr<pid>.<host>...") with another pid written in.
std::string with_pid(const std::string& name, pid_t pid) {
  char hex[24];
  std::snprintf(hex, sizeof hex, "%lx", static_cast<unsigned long>(pid));
  return ".gr" + std::string(hex) + name.substr(name.find('.', 3));
}

}  // namespace

TEST_CASE("a writer ended by SIGINT or SIGTERM mid output set leaves no temporary and dies by that signal",
          "[raster][io][temporaries]") {
  for (int sig : {SIGINT, SIGTERM}) {
    CAPTURE(sig);
    TempDir dir;
    ChildProcess writer({GRADRASTER_INTERRUPTED_WRITER, dir.path().string()});
    REQUIRE(writer.wait_for_output("staged", 30));
    REQUIRE(entries(dir).size() == 2);  // both temporaries exist
    ::kill(writer.pid(), sig);
    const int status = writer.wait(30);
    INFO(describe_status(status) << "\n" << writer.output());
    CHECK((WIFSIGNALED(status) && WTERMSIG(status) == sig));
    CHECK(entries(dir).empty());
  }
}

TEST_CASE("committed and abandoned output sets give their registrations back", "[raster][io][temporaries]") {
  TempDir dir;
  const std::size_t before = registered_temporaries();
  for (int i = 0; i < 140; ++i) {  // more than the table holds (128): slots are given back
    OutputSet outputs;
    outputs.stage(dir.file("a.bin"), "abc", 3);
    CHECK(registered_temporaries() == before + 1);
    if (i % 2) outputs.commit();
  }
  CHECK(registered_temporaries() == before);
  CHECK(entries(dir) == std::vector<std::string>{"a.bin"});
}

TEST_CASE("temporaries of dead processes are removed - live ones, foreign hosts and look-alikes stay",
          "[raster][io][temporaries]") {
  TempDir dir, outside;
  const std::string own = temporary_file_name();  // ".gr<pid>.<host>.<n>.tmp"
  const pid_t dead = dead_pid();
  const std::string stale = with_pid(own, dead), live = with_pid(own, ::getppid());
  dir.write(stale, "partial");
  dir.write(live, "being written");
  dir.write(own, "ours, being written");
  // Look-alikes: other suffixes, another host, upper case, a prefix, a folder.
  const std::string host_tag = own.substr(own.find('.', 3) + 1, 8);
  const std::string other_host = host_tag == "00000000" ? "00000001" : "00000000";
  std::string foreign = stale;
  foreign.replace(foreign.find(host_tag), 8, other_host);
  const std::vector<std::string> kept_files = {stale + ".bak", foreign, "x" + stale, ".GR" + stale.substr(3)};
  for (const std::string& name : kept_files) dir.write(name, "not a temporary");
  const std::string folder_named_like_a_file = with_pid(temporary_file_name(), dead);
  fs::create_directory(dir.file(folder_named_like_a_file));
  // A symlink with a stale name: it is not something we write, and its target stays.
  const std::string link = with_pid(temporary_file_name(), dead);
  REQUIRE(::symlink(outside.write("target.txt", "keep me").c_str(), dir.file(link).c_str()) == 0);
  // Staging folders (flat) of a dead and of a live process.
  const std::string stale_staging = with_pid(staging_folder_name(), dead);
  const std::string live_staging = with_pid(staging_folder_name(), ::getppid());
  for (const std::string& s : {stale_staging, live_staging}) {
    fs::create_directory(dir.file(s));
    dir.write(s + "/snapshot_0000.png", "png");
  }

  CHECK(remove_stale_temporaries(dir.path().string()) == 2);  // the stale file and the stale staging folder
  std::vector<std::string> expected = kept_files;
  for (const std::string& s : {live, own, folder_named_like_a_file, link, live_staging}) expected.push_back(s);
  std::sort(expected.begin(), expected.end());
  CHECK(entries(dir) == expected);
  CHECK(gr::testing::slurp(outside.file("target.txt")) == "keep me");
  CHECK(fs::exists(dir.file(live_staging + "/snapshot_0000.png")));
}

TEST_CASE("the next write into a folder removes the temporaries a killed writer left there",
          "[raster][io][temporaries]") {
  TempDir dir;
  {
    ChildProcess writer({GRADRASTER_INTERRUPTED_WRITER, dir.path().string()});
    REQUIRE(writer.wait_for_output("staged", 30));
    ::kill(writer.pid(), SIGKILL);  // no handler runs
    REQUIRE(writer.wait(30) != -1);
  }
  REQUIRE(entries(dir).size() == 2);
  OutputSet outputs;
  outputs.stage(dir.file("c.bin"), "c", 1);
  outputs.commit();
  CHECK(entries(dir) == std::vector<std::string>{"c.bin"});
}
