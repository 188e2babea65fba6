// run_fit_with_outputs: gradraster-fit's outputs appear in the output folder
// all together or not at all, none of them replaces an input, and a request
// over the memory budget is refused before anything runs or any folder is made.
#include <catch2/catch.hpp>

#include <filesystem>
#include <sstream>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "examples/common/cli_args.h"
#include "examples/fit/fit_outputs.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/temp_dir.h"

using gr::testing::slurp;
using gr::testing::TempDir;
namespace fs = std::filesystem;

namespace {

fit::FitOptions quick_options(const std::string& out_dir) {
  fit::FitOptions options;
  options.iterations = 2;
  options.size = 24;
  options.views = 1;
  options.start_subdivisions = 1;
  options.reference_subdivisions = 1;
  options.out_dir = out_dir;
  return options;
}

}  // namespace

TEST_CASE("fit outputs: a successful run moves every file into the new output folder", "[examples][fit][files]") {
  TempDir dir;
  std::ostringstream log;
  const fit::FitResult r = fit::run_fit_with_outputs(quick_options(dir.file("a/out")), log);
  REQUIRE(!r.files.empty());
  for (const std::string& f : r.files) {
    INFO(f);
    CHECK(fs::path(f).parent_path() == fs::path(dir.file("a/out")));
    CHECK(fs::is_regular_file(f));
  }
  int entries = 0;
  for (auto it = fs::directory_iterator(dir.file("a/out")); it != fs::directory_iterator(); ++it) ++entries;
  CHECK(entries == static_cast<int>(r.files.size()));  // no staging folder left
}

TEST_CASE("fit outputs: a run over the memory budget is refused before making its folder", "[examples][fit][memory]") {
  TempDir dir;
  fit::FitOptions options = quick_options(dir.file("out"));
  options.size = 4096;
  options.views = 64;
  std::ostringstream log;
  CHECK_THROWS_WITH(fit::run_fit_with_outputs(options, log),
                    Catch::Contains("gradraster-fit --size 4096 with 64 views needs 294928 MiB"));
  CHECK_THROWS_AS(fit::run_fit_with_outputs(options, log), gr::MemoryError);
  CHECK(dir.count() == 0);
}

TEST_CASE("fit outputs: a failed run leaves neither files nor the folder it created", "[examples][fit][files]") {
  TempDir dir;
  std::ostringstream log;
  fit::FitOptions options = quick_options(dir.file("new/out"));
  options.mesh_path = dir.file("missing.obj");  // fails after the folder exists
  CHECK_THROWS_AS(fit::run_fit_with_outputs(options, log), gr::IOError);
  CHECK(dir.count() == 0);
  // An existing folder whose loss.png is a folder: no output moves in, the folder stays.
  fs::create_directories(dir.file("out/loss.png"));
  CHECK_THROWS_WITH(fit::run_fit_with_outputs(quick_options(dir.file("out")), log), Catch::Contains("loss.png"));
  int entries = 0;
  for (auto it = fs::directory_iterator(dir.file("out")); it != fs::directory_iterator(); ++it) ++entries;
  CHECK(entries == 1);
}

TEST_CASE("fit outputs: an input inside the output folder under an output's name is refused before the run",
          "[examples][fit][files][distinct_files]") {
  TempDir dir;
  gr::raster::Mesh cube = gr::raster::make_cube();
  cube.uvs = gr::Tensor::zeros({cube.num_vertices(), 2});
  fs::create_directories(dir.file("out"));
  gr::raster::save_obj(dir.file("out/fitted.obj"), cube);
  gr::raster::write_png(dir.file("out/loss.png"), gr::Tensor::full({2, 2, 3}, 0.5));
  const std::string mesh = slurp(dir.file("out/fitted.obj")), png = slurp(dir.file("out/loss.png"));
  std::ostringstream log;
  fit::FitOptions options = quick_options(dir.file("out"));
  options.mesh_path = dir.file("out/./fitted.obj");
  CHECK_THROWS_WITH(fit::run_fit_with_outputs(options, log),
                    Catch::Contains("(its fitted.obj)") && Catch::Contains("is the same file as --mesh"));
  CHECK_THROWS_AS(fit::run_fit_with_outputs(options, log), gr::cli::UsageError);
  options.mesh_path = dir.file("cube.obj");
  gr::raster::save_obj(options.mesh_path, cube);
  options.texture_path = dir.file("out/loss.png");
  CHECK_THROWS_WITH(fit::run_fit_with_outputs(options, log),
                    Catch::Contains("(its loss.png)") && Catch::Contains("is the same file as --texture"));
  CHECK(log.str().empty());  // refused before anything ran
  CHECK(slurp(dir.file("out/fitted.obj")) == mesh);
  CHECK(slurp(dir.file("out/loss.png")) == png);
}

TEST_CASE("fit outputs: the texture a mesh's MTL names is not replaced by an output", "[examples][fit][files][distinct_files]") {
  TempDir dir;
  fs::create_directories(dir.file("out"));
  gr::raster::write_png(dir.file("out/loss.png"), gr::Tensor::full({4, 4, 3}, 0.5));
  const std::string png = slurp(dir.file("out/loss.png"));
  gr::raster::Mesh cube = gr::raster::make_cube();
  cube.uvs = gr::Tensor::zeros({cube.num_vertices(), 2});
  cube.texture_path = dir.file("out/loss.png");
  gr::raster::save_obj(dir.file("cube.obj"), cube);  // cube.mtl's map_Kd names out/loss.png
  fit::FitOptions options = quick_options(dir.file("out"));
  options.mesh_path = dir.file("cube.obj");
  std::ostringstream log;
  CHECK_THROWS_WITH(fit::run_fit_with_outputs(options, log),
                    Catch::Contains("(its loss.png)") && Catch::Contains("is the same file as the input"));
  CHECK(slurp(dir.file("out/loss.png")) == png);
  int entries = 0;
  for (auto it = fs::directory_iterator(dir.file("out")); it != fs::directory_iterator(); ++it) ++entries;
  CHECK(entries == 1);  // no output moved in, no staging folder left
}
