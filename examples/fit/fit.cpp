// run_fit: builds the scene, renders the targets, then loops
// render -> loss -> backward -> Adam, writing snapshots along the way.
#include "examples/fit/fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <ostream>

#include "autodiff/error.h"
#include "autodiff/optim.h"
#include "examples/fit/geometry.h"
#include "examples/fit/plot.h"
#include "examples/fit/progress.h"
#include "examples/fit/scene.h"
#include "examples/fit/shading.h"
#include "examples/fit/snapshot.h"
#include "ops/ops.h"
#include "raster/image_io.h"
#include "raster/obj_io.h"

namespace fit {

using namespace gr;

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Root mean square over vertices of the distance between two [N, 3] tensors.
double rms_distance(const Tensor& a, const Tensor& b) {
  NoGradGuard no_grad;
  return std::sqrt(mean(sum(pow(a - b, 2.0), -1)).item());
}

std::string numbered(const std::string& dir, const char* stem, int iteration) {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%04d.png", stem, iteration);
  return (std::filesystem::path(dir) / name).string();
}

// Target renders: fixed images without gradient.
struct Targets {
  std::vector<Tensor> images, coverage;
};

// The image loss: mean over views of the mean squared difference on pixels
// covered in both images. Also hands back the current images for snapshots.
Tensor image_loss(const Tensor& positions, const Tensor& colours, const Scene& scene, const Targets& targets, int size,
                  std::vector<Tensor>* current_images) {
  Tensor total;
  for (std::size_t v = 0; v < scene.cameras.size(); ++v) {
    const Render current = render(positions, colours, scene.triangles, scene.cameras[v], size);
    const Tensor both = current.coverage * targets.coverage[v];
    const Tensor view_loss = mean(pow((current.image - targets.images[v]) * both, 2.0));
    total = total.defined() ? total + view_loss : view_loss;
    if (current_images) current_images->push_back(current.image.detach());
  }
  return total / double(scene.cameras.size());
}

}  // namespace

std::vector<int> snapshot_iterations(int iterations) {
  std::vector<int> at{0, iterations / 20, iterations / 5, iterations / 2, iterations};
  std::sort(at.begin(), at.end());
  at.erase(std::unique(at.begin(), at.end()), at.end());
  return at;
}

FitResult run_fit(const FitOptions& options, std::ostream& log) {
  const auto start = Clock::now();
  if (options.iterations < 1 || options.size < 1) throw ValueError("run_fit: iterations and size must be >= 1");
  set_num_threads(options.threads);
  std::filesystem::create_directories(options.out_dir);

  SceneOptions scene_options;
  scene_options.views = options.views;
  scene_options.mesh_path = options.mesh_path;
  scene_options.seed = options.seed;
  const Scene scene = make_scene(scene_options);

  FitResult result;
  result.scene_name = scene.name;
  result.vertices = scene.reference_positions.size(0);
  result.triangles = scene.triangles.size(0);

  Targets targets;
  {
    NoGradGuard no_grad;
    for (const Camera& camera : scene.cameras) {
      const Render r = render(scene.reference_positions, scene.reference_colours, scene.triangles, camera, options.size);
      targets.images.push_back(r.image);
      targets.coverage.push_back(r.coverage);
    }
  }

  // The parameters: vertex colours, and one offset per vertex along its start
  // normal (positions = start + offset * normal; tangential sliding would
  // change nothing visible, so it is left out of the search).
  Tensor colours = scene.start_colours.copy().set_requires_grad();
  Tensor offsets = Tensor::zeros({scene.start_positions.size(0), 1}).set_requires_grad();
  const Tensor start_normals = vertex_normals(scene.start_positions, scene.triangles);
  auto positions_from = [&](const Tensor& offset) { return scene.start_positions + start_normals * offset; };
  Tensor positions = scene.start_positions;
  Adam position_optimizer({offsets}, AdamOptions{options.position_lr});
  Adam colour_optimizer({colours}, AdamOptions{options.colour_lr});
  const UniformLaplacian laplacian(scene.triangles, positions.size(0));

  result.start_position_rms = rms_distance(positions, scene.reference_positions);
  result.start_colour_rms = rms_distance(colours, scene.reference_colours);

  const std::vector<int> snapshots = snapshot_iterations(options.iterations);
  auto write_strip = [&](int iteration, const std::vector<Tensor>& current) {
    if (!std::binary_search(snapshots.begin(), snapshots.end(), iteration)) return;
    result.files.push_back(numbered(options.out_dir, "snapshot", iteration));
    write_snapshot(result.files.back(), targets.images, current);
  };

  ProgressBar progress(options.iterations, log, options.interactive);
  const auto loop_start = Clock::now();
  for (int it = 0; it < options.iterations; ++it) {
    // Learning rates decay geometrically to 10% at the end.
    const double decay = std::pow(0.1, double(it) / options.iterations);
    position_optimizer.set_lr(options.position_lr * decay);
    colour_optimizer.set_lr(options.colour_lr * decay);

    std::vector<Tensor> current;
    positions = positions_from(offsets);
    const Tensor loss_image = image_loss(positions, colours, scene, targets, options.size, &current);
    const Tensor loss = loss_image + options.laplacian_weight * laplacian.penalty(positions);
    backward(loss);
    position_optimizer.step();
    colour_optimizer.step();
    position_optimizer.zero_grad();
    colour_optimizer.zero_grad();

    result.losses.push_back(loss_image.item());
    write_strip(it, current);
    if (options.progress_bar) progress.update(it + 1, result.losses.back());
  }
  const double loop_seconds = seconds_since(loop_start);
  if (options.progress_bar) progress.finish();

  // Final state: one more render without gradient.
  {
    NoGradGuard no_grad;
    positions = positions_from(offsets);
    std::vector<Tensor> current;
    result.losses.push_back(image_loss(positions, colours, scene, targets, options.size, &current).item());
    write_strip(options.iterations, current);
  }

  result.files.push_back((std::filesystem::path(options.out_dir) / "loss.png").string());
  raster::write_png(result.files.back(), plot_loss_curve(result.losses));

  raster::Mesh fitted;
  fitted.positions = positions.detach().copy();
  fitted.triangles = scene.triangles;
  {
    NoGradGuard no_grad;
    fitted.normals = vertex_normals(fitted.positions, fitted.triangles);
  }
  result.files.push_back((std::filesystem::path(options.out_dir) / "fitted.obj").string());
  raster::save_obj(result.files.back(), fitted);

  result.positions = positions.detach();
  result.colours = colours.detach();
  result.initial_loss = result.losses.front();
  result.final_loss = result.losses.back();
  result.final_position_rms = rms_distance(positions, scene.reference_positions);
  result.final_colour_rms = rms_distance(colours, scene.reference_colours);
  result.iterations_per_second = loop_seconds > 0 ? options.iterations / loop_seconds : 0;
  result.seconds = seconds_since(start);
  return result;
}

}  // namespace fit
