// gradraster-fit's reference inputs (issue 30 item 12): a texture the user
// names with --texture is used or refused, never ignored; a texture or MTL the
// OBJ names but that is missing is a warning naming the file (the reference
// then wears the procedural pattern).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "autodiff/base/error.h"
#include "examples/fit/cli.h"
#include "examples/fit/fit.h"
#include "examples/fit/scene.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/temp_dir.h"

using gr::testing::TempDir;

namespace {

fit::SceneOptions scene_of(const std::string& mesh, const std::string& texture = "") {
  fit::SceneOptions o;
  o.views = 1;
  o.mesh_path = mesh;
  o.texture_path = texture;
  o.start_subdivisions = 0;
  return o;
}

// A cube with uvs whose MTL names `texture` (written by save_obj).
std::string cube_with_texture(const TempDir& dir, const std::string& texture) {
  gr::raster::Mesh cube = gr::raster::make_cube();
  cube.uvs = gr::Tensor::zeros({cube.num_vertices(), 2});
  cube.texture_path = texture;
  gr::raster::save_obj(dir.file("cube.obj"), cube);
  return dir.file("cube.obj");
}

}  // namespace

TEST_CASE("fit reference: --texture without --mesh is a usage error, not ignored", "[examples][fit]") {
  const fit::CommandLine cl = fit::parse_command_line({"--texture", "t.png"});
  CHECK(cl.action == fit::CommandLine::Action::Error);
  CHECK_THAT(cl.error, Catch::StartsWith("--texture: applies only with --mesh"));
  CHECK_THROWS_WITH(fit::make_scene(scene_of("", "t.png")), Catch::StartsWith("--texture"));
}

TEST_CASE("fit reference: --texture for a mesh without uvs is refused, naming both files", "[examples][fit]") {
  TempDir dir;
  std::ofstream(dir.file("plain.obj")) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";
  gr::raster::write_png(dir.file("t.png"), gr::Tensor::full({2, 2, 3}, 0.5));
  CHECK_THROWS_WITH(fit::make_scene(scene_of(dir.file("plain.obj"), dir.file("t.png"))),
                    Catch::StartsWith("--texture '") && Catch::Contains("plain.obj") &&
                        Catch::Contains("has no texture coordinates"));
}

TEST_CASE("fit reference: a missing MTL or texture is a warning naming it, and the pattern is used", "[examples][fit]") {
  TempDir dir;
  // The MTL names a texture that is not there.
  const std::string mesh = cube_with_texture(dir, dir.file("gone.png"));
  const fit::Scene missing_texture = fit::make_scene(scene_of(mesh));
  CHECK(!missing_texture.reference_material.texture.defined());
  REQUIRE(missing_texture.warnings.size() >= 2);
  CHECK_THAT(missing_texture.warnings[0], Catch::Contains("gone.png"));
  CHECK_THAT(missing_texture.warnings.back(), Catch::Contains("no texture was found") &&
                                                  Catch::Contains("procedural stripe pattern"));
  // No MTL at all.
  std::filesystem::remove(dir.file("cube.mtl"));
  const fit::Scene missing_mtl = fit::make_scene(scene_of(mesh));
  REQUIRE(!missing_mtl.warnings.empty());
  CHECK_THAT(missing_mtl.warnings[0], Catch::Contains("cube.mtl"));

  // The run prints them to FitOptions::warnings.
  fit::FitOptions o;
  o.mesh_path = mesh;
  o.iterations = 1;
  o.size = 16;
  o.views = 1;
  o.start_subdivisions = 0;
  o.write_outputs = false;
  o.progress_bar = false;
  std::ostringstream log, warnings;
  o.warnings = &warnings;
  fit::run_fit(o, log);
  CHECK_THAT(warnings.str(), Catch::StartsWith("gradraster-fit: warning: ") && Catch::Contains("cube.mtl") &&
                                 Catch::Contains("procedural stripe pattern"));
}

TEST_CASE("fit reference: a texture the MTL names for a mesh without uvs is a warning", "[examples][fit]") {
  TempDir dir;
  gr::raster::write_png(dir.file("t.png"), gr::Tensor::full({2, 2, 3}, 0.5));
  // An OBJ without vt whose material names t.png.
  std::ofstream(dir.file("m.mtl")) << "newmtl a\nmap_Kd t.png\n";
  std::ofstream(dir.file("m.obj")) << "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                                      "f 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";
  const fit::Scene s = fit::make_scene(scene_of(dir.file("m.obj")));
  CHECK(!s.reference_material.texture.defined());
  REQUIRE(!s.warnings.empty());
  CHECK_THAT(s.warnings.back(), Catch::Contains("t.png") && Catch::Contains("is not used"));
}
