// The fit example's core (examples/fit) at a tiny size: the shape fit lowers
// the loss and raises the silhouette IoU past stated thresholds, pose mode
// recovers the rotation, outputs are written and parameters stay finite; the
// Laplacian, the vertex normals, the seam uvs, the plot and the flags behave.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "examples/fit/cli.h"
#include "examples/fit/fit.h"
#include "examples/fit/geometry.h"
#include "examples/fit/plot.h"
#include "examples/fit/shading.h"
#include "examples/fit/snapshot.h"
#include "examples/fit/snapshot_writer.h"
#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"
#include "raster/procedural.h"
#include "raster/temp_dir.h"
#include "test_support.h"

using namespace gr;

namespace {

// The shape fit at a tiny size: a 642-point sphere against a 1280-triangle
// reference, 3 views of 48x48, 60 steps (about 0.6 s on 2 cores).
fit::FitOptions tiny_shape_options(const std::string& out_dir) {
  fit::FitOptions options;
  options.iterations = 60;
  options.size = 48;
  options.views = 3;
  options.start_subdivisions = 3;
  options.reference_subdivisions = 3;
  options.out_dir = out_dir;
  return options;
}

std::string snapshot_name(int iteration) {
  char name[32];
  std::snprintf(name, sizeof name, "snapshot_%04d.png", iteration);
  return name;
}

}  // namespace

TEST_CASE("fit example: a sphere fitted to 3 views for 60 steps lowers the loss 10x and reaches silhouette IoU 0.93",
          "[examples][fit]") {
  gr::testing::TempDir dir;
  const fit::FitOptions options = tiny_shape_options(dir.file("out"));
  std::ostringstream log;
  const fit::FitResult r = fit::run_fit(options, log);

  // Measured: loss 0.040 -> 0.00076 (53x), IoU 0.716 -> 0.977.
  INFO("loss " << r.initial_loss << " -> " << r.final_loss << ", IoU " << r.initial_iou << " -> " << r.final_iou);
  REQUIRE(r.losses.size() == 61);
  CHECK(r.final_loss * 10 <= r.initial_loss);
  CHECK(r.initial_iou < 0.8);  // the start sphere really is the wrong shape
  CHECK(r.final_iou >= 0.93);
  for (double l : r.losses) CHECK(std::isfinite(l));
  CHECK(gr::testing::all_finite(r.positions));
  CHECK(gr::testing::all_finite(r.colours));
  CHECK(log.str().find("it/s") != std::string::npos);

  for (int it : fit::snapshot_iterations(60)) {
    const Tensor strip = raster::read_image(dir.file("out/") + snapshot_name(it), 3);
    CHECK(strip.size(0) == 3 * 48 + 2 * 2);  // three views and two gutters
    CHECK(strip.size(1) == 3 * 48 + 4);      // target | current | difference with two gutters
  }
  CHECK(raster::read_image(dir.file("out/loss.png"), 3).size(1) == 640);
  const raster::Mesh fitted = raster::load_obj(dir.file("out/fitted.obj"));
  CHECK(fitted.num_triangles() == r.triangles);
  CHECK(gr::testing::all_finite(fitted.positions));
}

TEST_CASE("fit example: the shape fit is the same bits for 1, 2 and 8 threads (its views run concurrently)",
          "[examples][fit][parallel]") {
  gr::testing::TempDir dir;
  auto run = [&](int threads, fit::Appearance appearance) {
    fit::FitOptions options = tiny_shape_options(dir.file("out"));
    options.iterations = 12;
    options.size = 32;
    options.fit_camera = true;  // each view also differentiates its own camera correction
    options.appearance = appearance;
    options.texture_size = 16;
    options.write_outputs = false;
    options.progress_bar = false;
    options.threads = threads;
    std::ostringstream log;
    return fit::run_fit(options, log);
  };
  for (fit::Appearance appearance : {fit::Appearance::Colours, fit::Appearance::Texture}) {
    const fit::FitResult one = run(1, appearance);
    for (int threads : {2, 8}) {
      INFO(threads << " threads, " << (appearance == fit::Appearance::Texture ? "texture" : "colours"));
      const fit::FitResult r = run(threads, appearance);
      CHECK(r.losses == one.losses);
      CHECK(r.initial_iou == one.initial_iou);
      CHECK(r.final_iou == one.final_iou);
      CHECK(r.positions.to_vector() == one.positions.to_vector());
      const Tensor& fitted = appearance == fit::Appearance::Texture ? r.texture : r.colours;
      CHECK(fitted.to_vector() == (appearance == fit::Appearance::Texture ? one.texture : one.colours).to_vector());
      CHECK(r.final_rotation_error == one.final_rotation_error);
    }
  }
  gr::set_num_threads(0);
}

TEST_CASE("fit example: snapshots written beside the loop are the bytes write_snapshot writes", "[examples][fit][files]") {
  gr::testing::TempDir dir;
  const Tensor target = Tensor::full({8, 8, 3}, 0.25), current = Tensor::full({8, 8, 3}, 0.75);
  fit::write_snapshot(dir.file("direct.png"), {target, target}, {current, target});
  {
    fit::SnapshotWriter writer;
    writer.write(dir.file("beside_1.png"), {target, target}, {current, target});
    writer.write(dir.file("beside_2.png"), {target}, {current});
    writer.finish();
    CHECK(gr::testing::slurp(dir.file("beside_1.png")) == gr::testing::slurp(dir.file("direct.png")));
    CHECK(std::filesystem::exists(dir.file("beside_2.png")));
  }
  // A write that fails is reported by finish(), naming the file.
  fit::SnapshotWriter writer;
  writer.write(dir.file("no_such_folder/x.png"), {target}, {current});
  CHECK_THROWS_WITH(writer.finish(), Catch::Contains("no_such_folder"));
  CHECK_THROWS(writer.finish());  // and stays reported
}

TEST_CASE("fit example: fitting a texture lowers the loss 10x and writes the texture with the OBJ",
          "[examples][fit]") {
  gr::testing::TempDir dir;
  fit::FitOptions options = tiny_shape_options(dir.file("out"));
  options.iterations = 40;
  options.appearance = fit::Appearance::Texture;
  options.texture_size = 32;
  std::ostringstream log;
  const fit::FitResult r = fit::run_fit(options, log);

  // Measured: loss 0.040 -> 0.0014 (29x), IoU 0.716 -> 0.972.
  INFO("loss " << r.initial_loss << " -> " << r.final_loss << ", IoU " << r.final_iou);
  CHECK(r.final_loss * 10 <= r.initial_loss);
  CHECK(r.final_iou >= 0.93);
  REQUIRE(r.texture.shape() == Shape({32, 64, 3}));
  CHECK(gr::testing::all_finite(r.texture));
  CHECK(raster::read_image(dir.file("out/fitted_texture.png"), 3).shape() == Shape({32, 64, 3}));
  const raster::Mesh fitted = raster::load_obj(dir.file("out/fitted.obj"));
  CHECK(fitted.has_uvs());
  CHECK(std::filesystem::equivalent(fitted.texture_path, dir.file("out/fitted_texture.png")));
}

TEST_CASE("fit example: pose mode recovers a rotation 25 degrees off to within 3 degrees from one image",
          "[examples][fit]") {
  gr::testing::TempDir dir;
  fit::FitOptions options;
  options.mode = fit::Mode::Pose;
  options.iterations = 60;
  options.size = 48;
  options.reference_subdivisions = 3;
  options.out_dir = dir.file("out");
  std::ostringstream log;
  const fit::FitResult r = fit::run_fit(options, log);

  // Measured for seeds 1-5: 25 -> 0.4-1.2 degrees, 0.15 -> 0.004-0.015 units.
  INFO("rotation " << r.initial_rotation_error << " -> " << r.final_rotation_error << " deg, translation "
                   << r.initial_translation_error << " -> " << r.final_translation_error);
  CHECK(r.initial_rotation_error == Approx(25).margin(0.01));
  CHECK(r.initial_translation_error == Approx(0.15).margin(1e-4));
  CHECK(r.final_rotation_error < 3.0);
  CHECK(r.final_translation_error < 0.05);
  CHECK(r.final_loss * 10 <= r.initial_loss);
  CHECK(r.final_iou > r.initial_iou);
  CHECK(std::filesystem::exists(dir.file("out/loss.png")));
  CHECK(std::filesystem::exists(dir.file("out/posed.obj")));
  CHECK(std::filesystem::exists(dir.file("out/") + snapshot_name(60)));

  // Bit-identical for another thread count.
  options.threads = 1;
  options.out_dir = dir.file("out1");
  const fit::FitResult one = fit::run_fit(options, log);
  CHECK(one.losses == r.losses);
  options.threads = 0;
}

TEST_CASE("fit example: with --fit-camera the cameras start off and the fit still converges", "[examples][fit]") {
  gr::testing::TempDir dir;
  fit::FitOptions options = tiny_shape_options(dir.file("out"));
  options.iterations = 40;
  options.fit_camera = true;
  std::ostringstream log;
  const fit::FitResult r = fit::run_fit(options, log);
  // Measured: loss 0.040 -> 0.0019 (21x). At this size the camera errors barely move (2 -> 1.9 degrees);
  // the default run (6 views, 128x128, 300 steps) takes them from 2 to 0.7 degrees.
  INFO("loss " << r.initial_loss << " -> " << r.final_loss << ", camera " << r.final_rotation_error << " deg");
  CHECK(r.initial_rotation_error == Approx(2).margin(0.01));
  CHECK(r.initial_translation_error == Approx(0.03).margin(1e-4));
  CHECK(std::isfinite(r.final_rotation_error));
  CHECK(r.final_loss * 10 <= r.initial_loss);
}

TEST_CASE("fit example: the start sphere's uvs never jump across the seam inside a triangle", "[examples][fit]") {
  const fit::SurfaceMesh s = fit::sphere_surface(2, 0.5);
  REQUIRE(s.num_points() == 162);
  REQUIRE(s.uvs.size(0) == s.render_to_point.size(0));
  CHECK(s.uvs.size(0) > s.num_points());  // seam copies exist
  for (std::int64_t f = 0; f < s.num_triangles(); ++f) {
    double lo = 2, hi = -1;
    for (std::int64_t k = 0; k < 3; ++k) {
      const auto v = static_cast<std::int64_t>(s.triangles.at({f, k}));
      lo = std::min(lo, s.uvs.at({v, 0})), hi = std::max(hi, s.uvs.at({v, 0}));
      // A render vertex is a copy of the point its triangle names.
      CHECK(s.render_to_point.at({v}) == s.point_triangles.at({f, k}));
    }
    CHECK(hi - lo < 0.6);  // seam triangles spanned ~1 before the split; those by the poles span up to ~0.59
  }
  for (std::int64_t i = 0; i < s.num_points(); ++i) {
    double r2 = 0;
    for (std::int64_t k = 0; k < 3; ++k) r2 += s.positions.at({i, k}) * s.positions.at({i, k});
    CHECK(std::sqrt(r2) == Approx(0.5).epsilon(1e-5));
  }
  CHECK(fit::coverage_iou(Tensor::from_values({1, 1, 0, 0}, {4}), Tensor::from_values({1, 0, 1, 0}, {4})) ==
        Approx(1.0 / 3.0));
}

TEST_CASE("fit example: the uniform Laplacian is zero on a flat grid and vertex normals point out of a sphere",
          "[examples][fit]") {
  const raster::Mesh plane = raster::make_plane(4, 4);
  const gr::MeshLaplacian laplacian(plane.triangles, plane.num_vertices());
  const Tensor l = laplacian.apply(plane.positions);
  for (std::int64_t i = 0; i < plane.num_vertices(); ++i) CHECK(l.at({i, 2}) == 0.0);  // flat: no z offset

  const raster::Mesh sphere = raster::make_icosphere(2);
  const Tensor n = gr::vertex_normals(sphere.positions, sphere.triangles);
  for (std::int64_t i = 0; i < sphere.num_vertices(); ++i) {
    double along = 0;
    for (std::int64_t k = 0; k < 3; ++k) along += n.at({i, k}) * sphere.positions.at({i, k});
    CHECK(along > 0.99);  // unit sphere: the normal is the position
  }
}

TEST_CASE("fit example: gradients of vertex normals and of the Laplacian penalty match finite differences",
          "[examples][fit][gradcheck]") {
  const raster::Mesh mesh = raster::make_icosphere(0);
  const gr::MeshLaplacian laplacian(mesh.triangles, mesh.num_vertices());
  Tensor p = gr::testing::random_input({mesh.num_vertices(), 3}, -0.05, 0.05, 7);
  {
    NoGradGuard no_grad;
    p = (p + cast(mesh.positions, DType::Float64)).copy().set_requires_grad();
  }
  gr::testing::require_gradcheck("vertex_normals", [&](const std::vector<Tensor>& in) {
    return gr::vertex_normals(in[0], mesh.triangles);
  }, {p});
  gr::testing::require_gradcheck("laplacian penalty", [&](const std::vector<Tensor>& in) {
    return fit::laplacian_penalty(laplacian, in[0]);
  }, {p});
}

TEST_CASE("fit example: shading and the loss run as fused passes with the tensor ops' values and gradients",
          "[examples][fit][gradcheck]") {
  const Tensor albedo = gr::testing::random_input({5, 7, 3}, 0, 1, 11);
  const Tensor normal = gr::testing::random_input({5, 7, 3}, -1, 1, 12);
  Tensor coverage = gr::testing::random_input({5, 7, 1}, 0, 1, 13).detach();
  coverage = cast(greater(coverage, Tensor::scalar(0.5)), DType::Float64);  // 0 or 1, as a G-buffer's coverage
  const Tensor light = Tensor::from_values({0.36, 0.48, 0.8}, {3}, DType::Float64);
  const Tensor background = Tensor::from_values({0.1, 0.2, 0.3}, {3}, DType::Float64);
  const Tensor rgba = gr::testing::random_input({6, 5, 4}, 0, 1, 14);
  const Tensor target = gr::testing::random_input({6, 5, 4}, 0, 1, 15).detach();

  // Fused (in float32, at an image size, as the fit runs them), so the passes
  // really replace the ops one by one ...
  const auto image = [](std::int64_t c, std::uint64_t seed) {
    return cast(gr::testing::random_input({32, 32, c}, 0, 1, seed), DType::Float32).detach().set_requires_grad();
  };
  const auto f32 = [](const Tensor& t) { return cast(t, DType::Float32).detach(); };
  CHECK(map_rows_fuses(fit::shade_over_background_rows, {image(3, 1), image(3, 2), image(1, 3).detach()},
                       {f32(light), f32(background)}));
  CHECK(map_rows_fuses(fit::colour_and_alpha_error_rows, {image(4, 4), image(4, 5).detach()}));
  // ... with their values: the shading bit for bit, the loss up to its summation order.
  {
    NoGradGuard no_grad;
    const Tensor eager = fit::lambert(albedo, normalize(normal), light) * coverage + background * (1.0 - coverage);
    CHECK(fit::shade_over_background(albedo, normal, coverage, light, background).to_vector() == eager.to_vector());
    const Tensor rgb_mse = mean(pow(slice(rgba, 2, 0, 3) - slice(target, 2, 0, 3), 2.0));
    const Tensor alpha_mse = mean(pow(slice(rgba, 2, 3, 4) - slice(target, 2, 3, 4), 2.0));
    CHECK(fit::colour_and_alpha_mse(rgba, target).item() == Approx((rgb_mse + alpha_mse).item()).epsilon(1e-14));
  }
  gr::testing::require_gradcheck("shade_over_background", [&](const std::vector<Tensor>& in) {
    return fit::shade_over_background(in[0], in[1], coverage, light, background);
  }, {albedo, normal});
  gr::testing::require_gradcheck("colour_and_alpha_mse", [&](const std::vector<Tensor>& in) {
    return fit::colour_and_alpha_mse(in[0], target);
  }, {rgba});
}

TEST_CASE("fit example: the loss plot has the requested size and draws the curve", "[examples][fit]") {
  std::vector<double> losses;
  for (int i = 0; i < 100; ++i) losses.push_back(0.1 * std::exp(-0.05 * i));
  const Tensor image = fit::plot_loss_curve(losses, 320, 200);
  REQUIRE(image.shape() == Shape({200, 320, 3}));
  int curve_pixels = 0;  // the curve is the only blue-dominant thing on the canvas
  const float* px = image.data<float>();
  for (std::int64_t i = 0; i < 200 * 320; ++i) curve_pixels += px[3 * i + 2] > 0.6f && px[3 * i] < 0.3f;
  CHECK(curve_pixels > 200);
}

TEST_CASE("fit example: flags parse, and bad flags are errors", "[examples][fit]") {
  using Action = fit::CommandLine::Action;
  const fit::CommandLine ok = fit::parse_command_line(
      {"--iterations", "12", "--size=64", "--views", "3", "--out", "x", "--threads", "1", "--seed", "5", "--mesh", "m.obj",
       "--texture", "t.png", "--mode", "pose", "--fit", "texture", "--fit-camera", "--subdivisions", "2",
       "--device", "vulkan"});
  REQUIRE(ok.action == Action::Run);
  CHECK(ok.options.iterations == 12);
  CHECK(ok.options.size == 64);
  CHECK(ok.options.views == 3);
  CHECK(ok.options.out_dir == "x");
  CHECK(ok.options.threads == 1);
  CHECK(ok.options.seed == 5);
  CHECK(ok.options.mesh_path == "m.obj");
  CHECK(ok.options.texture_path == "t.png");
  CHECK(ok.options.mode == fit::Mode::Pose);
  CHECK(ok.options.appearance == fit::Appearance::Texture);
  CHECK(ok.options.fit_camera);
  CHECK(ok.options.start_subdivisions == 2);
  CHECK(ok.device == "vulkan");
  const fit::CommandLine defaults = fit::parse_command_line({});
  CHECK(defaults.options.mode == fit::Mode::Shape);
  CHECK(defaults.options.appearance == fit::Appearance::Colours);
  CHECK_FALSE(defaults.options.fit_camera);
  CHECK(defaults.device == "cpu");
  CHECK(fit::parse_command_line({}).action == Action::Run);
  CHECK(fit::parse_command_line({"--help"}).action == Action::Help);
  for (const std::vector<std::string>& bad : std::vector<std::vector<std::string>>{
           {"--iterations", "0"}, {"--size", "12abc"}, {"--views"}, {"--frobnicate", "1"}, {"stray"}, {"--threads", "-1"},
           {"--mode", "walk"}, {"--fit", "normals"}, {"--fit-camera=1"}, {"--texture"}, {"--subdivisions", "9"},
           {"--device", "cuda"}})
    CHECK(fit::parse_command_line(bad).action == Action::Error);
}
