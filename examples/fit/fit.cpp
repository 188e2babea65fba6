// run_fit: builds the scene, renders the targets, then loops
// render -> loss -> backward -> Adam, writing snapshots along the way.
#include "examples/fit/fit.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <ostream>
#include <random>

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
constexpr double kPi = 3.14159265358979323846;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string in_dir(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

std::string numbered(const std::string& dir, const char* stem, int iteration) {
  char name[64];
  std::snprintf(name, sizeof name, "%s_%04d.png", stem, iteration);
  return in_dir(dir, name);
}

// Unit quaternions (w, x, y, z) in plain doubles, for setting up poses.
using Quaternion = std::array<double, 4>;

Quaternion axis_angle(const std::array<double, 3>& axis, double degrees) {
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  const double h = 0.5 * degrees * kPi / 180, s = std::sin(h) / n;
  return {std::cos(h), s * axis[0], s * axis[1], s * axis[2]};
}

Quaternion multiply(const Quaternion& a, const Quaternion& b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3], a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1], a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}

std::array<double, 3> random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  std::array<double, 3> v{normal(rng), normal(rng), normal(rng)};
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (double& x : v) x /= n;
  return v;
}

// A rigid transform translate(t) * rotation(q) as tensors (differentiable in q and t).
Tensor rigid(const Tensor& q, const Tensor& t) { return matmul(translate(t), rotation_quaternion(q)); }

// Rotation angle (degrees) between the 3x3 blocks of two rigid 4x4 matrices,
// and the distance between their translation columns.
void rigid_error(const Tensor& a, const Tensor& b, double& degrees, double& distance) {
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  double trace = 0, d2 = 0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) trace += x[4 * r + c] * y[4 * r + c];  // trace(A^T B)
    d2 += (x[4 * r + 3] - y[4 * r + 3]) * (x[4 * r + 3] - y[4 * r + 3]);
  }
  degrees = std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0)) * 180 / kPi;
  distance = std::sqrt(d2);
}

double mse(const Tensor& a, const Tensor& b) {
  NoGradGuard no_grad;
  return mean(pow(a - b, 2.0)).item();
}

// A progress bar, snapshots and the loss record shared by both modes.
class Run {
 public:
  Run(const FitOptions& options, int iterations, std::ostream& log, FitResult& result)
      : options_(options), result_(result), snapshots_(snapshot_iterations(iterations)),
        progress_(iterations, log, options.interactive) {}

  void snapshot(int iteration, const std::vector<Tensor>& targets, const std::vector<Tensor>& current) {
    if (!std::binary_search(snapshots_.begin(), snapshots_.end(), iteration)) return;
    result_.files.push_back(numbered(options_.out_dir, "snapshot", iteration));
    write_snapshot(result_.files.back(), targets, current);
  }
  void step_done(int done, double loss) {
    result_.losses.push_back(loss);
    if (options_.progress_bar) progress_.update(done, loss);
    if (options_.on_step) options_.on_step(done, loss);
  }
  void finish_loop() {
    if (options_.progress_bar) progress_.finish();
  }
  void write_plot() {
    result_.files.push_back(in_dir(options_.out_dir, "loss.png"));
    raster::write_png(result_.files.back(), plot_loss_curve(result_.losses));
  }

 private:
  const FitOptions& options_;
  FitResult& result_;
  std::vector<int> snapshots_;
  ProgressBar progress_;
};

// Writes the render vertices of `mesh` at `points` (with normals; with uvs and
// the texture when one is given) as an OBJ.
void write_mesh(const std::string& path, const SurfaceMesh& mesh, const Tensor& points, const Tensor& texture,
                const std::string& texture_file) {
  NoGradGuard no_grad;
  raster::Mesh out;
  out.positions = mesh.to_render(points.detach()).copy();
  out.triangles = mesh.triangles;
  out.normals = mesh.to_render(vertex_normals(points.detach(), mesh.point_triangles)).copy();
  if (texture.defined() && mesh.uvs.defined()) {
    raster::write_png(texture_file, texture.detach());
    out.uvs = mesh.uvs;
    out.texture_path = texture_file;
  }
  raster::save_obj(path, out);
}

FitResult run_shape(const FitOptions& options, std::ostream& log) {
  const auto start = Clock::now();
  const int iterations = options.iterations > 0 ? options.iterations : kDefaultShapeIterations;
  SceneOptions scene_options;
  scene_options.views = options.views;
  scene_options.mesh_path = options.mesh_path;
  scene_options.texture_path = options.texture_path;
  scene_options.reference_subdivisions = options.reference_subdivisions > 0 ? options.reference_subdivisions : 5;
  scene_options.start_subdivisions = options.start_subdivisions;
  const Scene scene = make_scene(scene_options);
  const SurfaceMesh& mesh = scene.start;
  const std::size_t views = scene.cameras.size();

  FitResult result;
  result.mode = Mode::Shape;
  result.scene_name = scene.name;
  result.points = mesh.num_points();
  result.triangles = mesh.num_triangles();
  result.iterations = iterations;

  std::vector<Tensor> target_images, target_coverage, target_alpha;
  {
    NoGradGuard no_grad;
    for (const Camera& camera : scene.cameras) {
      const Render r = render(scene.reference, scene.reference.positions, scene.reference_material,
                              matmul(camera.projection, camera.view), camera.light, scene.background, options.size);
      target_images.push_back(r.image);
      target_coverage.push_back(r.coverage);
      target_alpha.push_back(r.alpha);
    }
  }

  // Parameters: free point positions, and vertex colours or a texture, all starting grey.
  // Positions are free 3-D points: start + S^k(u) with one offset u per point
  // and S = I - L/2 (a half step towards the neighbours' mean), k =
  // smoothing_passes. S^k is invertible, so any positions can be reached, but a
  // gradient on one vertex moves its neighbourhood: a cheap stand-in for the
  // "large steps" preconditioner of Nicolet et al. 2021. Without it (k = 0) the
  // silhouette gradients, which reach only edge vertices, pull single vertices
  // into spikes and folds (measured: IoU 0.96 and a crumpled waist vs 0.99).
  Tensor offsets = Tensor::zeros({mesh.num_points(), 3}).set_requires_grad();
  const UniformLaplacian laplacian(mesh.point_triangles, mesh.num_points());
  auto positions_from = [&](const Tensor& u) {
    Tensor x = u;
    for (int k = 0; k < options.smoothing_passes; ++k) x = x - 0.5 * laplacian.apply(x);
    return mesh.positions + x;
  };
  Tensor positions = positions_from(offsets);
  Material material;
  Tensor appearance;
  if (options.appearance == Appearance::Texture) {
    appearance = Tensor::full({options.texture_size, 2 * options.texture_size, 3}, 0.5).set_requires_grad();
    material.texture = appearance;
  } else {
    appearance = Tensor::full({mesh.num_points(), 3}, 0.5).set_requires_grad();
    material.point_colours = appearance;
  }
  Adam position_optimizer({offsets}, AdamOptions{options.position_lr});
  Adam appearance_optimizer({appearance}, AdamOptions{options.colour_lr});

  // --fit-camera: every camera starts off by a random rigid error in view space
  // (about 2 degrees and 0.03 units), and a correction (q, t) per view is fitted:
  // view = (translate(t) rotate(q)) * error * true view.
  std::vector<Tensor> camera_errors, camera_q, camera_t;
  std::vector<Tensor> camera_params;
  if (options.fit_camera) {
    std::mt19937_64 rng(options.seed);
    for (std::size_t v = 0; v < views; ++v) {
      const Quaternion qe = axis_angle(random_unit(rng), 2.0);
      const auto te = random_unit(rng);
      camera_errors.push_back(rigid(Tensor::from_values({qe[0], qe[1], qe[2], qe[3]}, {4}),
                                    Tensor::from_values({0.03 * te[0], 0.03 * te[1], 0.03 * te[2]}, {3})));
      camera_q.push_back(Tensor::from_values({1, 0, 0, 0}, {4}).set_requires_grad());
      camera_t.push_back(Tensor::zeros({3}).set_requires_grad());
      camera_params.push_back(camera_q.back());
      camera_params.push_back(camera_t.back());
    }
  }
  std::unique_ptr<Adam> camera_optimizer;
  if (options.fit_camera) camera_optimizer = std::make_unique<Adam>(camera_params, AdamOptions{options.camera_lr});
  auto view_projection = [&](std::size_t v) {
    const Camera& c = scene.cameras[v];
    if (!options.fit_camera) return matmul(c.projection, c.view);
    return matmul(c.projection, matmul(rigid(camera_q[v], camera_t[v]), matmul(camera_errors[v], c.view)));
  };
  auto camera_error = [&](double& degrees, double& distance) {
    NoGradGuard no_grad;
    degrees = distance = 0;
    for (std::size_t v = 0; v < views; ++v) {
      double d, t;
      rigid_error(matmul(rigid(camera_q[v], camera_t[v]), camera_errors[v]), identity4(), d, t);
      degrees += d / views, distance += t / views;
    }
  };
  if (options.fit_camera) camera_error(result.initial_rotation_error, result.initial_translation_error);

  // One pass over the views: the loss (mean over views of the per-pixel
  // colour MSE plus alpha-mask MSE), the current images and the mean silhouette IoU.
  auto image_loss = [&](std::vector<Tensor>& current, double& iou) {
    Tensor total;
    iou = 0;
    for (std::size_t v = 0; v < views; ++v) {
      const Camera& c = scene.cameras[v];
      const Render r = render(mesh, positions, material, view_projection(v), c.light, scene.background, options.size);
      // Colour MSE plus the alpha masks' MSE: a flap of the surface that takes
      // the background's colour is invisible to the first term, not the second.
      const Tensor view_loss = mean(pow(r.image - target_images[v], 2.0)) + mean(pow(r.alpha - target_alpha[v], 2.0));
      total = total.defined() ? total + view_loss : view_loss;
      current.push_back(r.image.detach());
      iou += coverage_iou(r.coverage, target_coverage[v]) / views;
    }
    return total / double(views);
  };

  Run run(options, iterations, log, result);
  const auto loop_start = Clock::now();
  for (int it = 0; it < iterations; ++it) {
    // Learning rates and the Laplacian weight decay geometrically to 10% at the end.
    const double decay = std::pow(0.1, double(it) / iterations);
    position_optimizer.set_lr(options.position_lr * decay);
    appearance_optimizer.set_lr(options.colour_lr * decay);
    if (camera_optimizer) camera_optimizer->set_lr(options.camera_lr * decay);

    std::vector<Tensor> current;
    double iou = 0;
    positions = positions_from(offsets);
    const Tensor loss_image = image_loss(current, iou);
    if (it == 0) result.initial_iou = iou;
    const Tensor loss = loss_image + options.laplacian_weight * decay * laplacian.penalty(positions);
    const double loss_value = loss_image.item();
    if (!std::isfinite(loss_value)) throw ValueError("fit: the loss became " + std::to_string(loss_value));
    backward(loss);
    position_optimizer.step();
    appearance_optimizer.step();
    if (camera_optimizer) camera_optimizer->step();
    position_optimizer.zero_grad();
    appearance_optimizer.zero_grad();
    if (camera_optimizer) camera_optimizer->zero_grad();

    run.snapshot(it, target_images, current);
    run.step_done(it + 1, loss_value);
  }
  const double loop_seconds = seconds_since(loop_start);
  run.finish_loop();

  // Final state: one more render without gradient.
  {
    NoGradGuard no_grad;
    positions = positions_from(offsets);
    std::vector<Tensor> current;
    result.losses.push_back(image_loss(current, result.final_iou).item());
    run.snapshot(iterations, target_images, current);
  }
  if (options.fit_camera) camera_error(result.final_rotation_error, result.final_translation_error);
  run.write_plot();

  result.files.push_back(in_dir(options.out_dir, "fitted.obj"));
  const std::string texture_file = in_dir(options.out_dir, "fitted_texture.png");
  write_mesh(result.files.back(), mesh, positions, material.texture, texture_file);
  if (material.texture.defined()) {
    result.files.push_back(in_dir(options.out_dir, "fitted.mtl"));
    result.files.push_back(texture_file);
  }

  result.positions = positions.detach();
  (options.appearance == Appearance::Texture ? result.texture : result.colours) = appearance.detach();
  result.initial_loss = result.losses.front();
  result.final_loss = result.losses.back();
  result.iterations_per_second = loop_seconds > 0 ? iterations / loop_seconds : 0;
  result.seconds = seconds_since(start);
  return result;
}

FitResult run_pose(const FitOptions& options, std::ostream& log) {
  const auto start = Clock::now();
  const int iterations = options.iterations > 0 ? options.iterations : kDefaultPoseIterations;
  SceneOptions scene_options;
  scene_options.views = 1;
  scene_options.mesh_path = options.mesh_path;
  scene_options.texture_path = options.texture_path;
  scene_options.reference_subdivisions = options.reference_subdivisions > 0 ? options.reference_subdivisions : 4;
  scene_options.start_subdivisions = 0;  // unused
  const Scene scene = make_scene(scene_options);
  const SurfaceMesh& mesh = scene.reference;
  const Camera& camera = scene.cameras[0];
  const Tensor vp = matmul(camera.projection, camera.view);

  FitResult result;
  result.mode = Mode::Pose;
  result.scene_name = scene.name;
  result.points = mesh.num_points();
  result.triangles = mesh.num_triangles();
  result.iterations = iterations;

  // The unknown pose: a random rotation of 30-90 degrees and a shift of up to
  // 0.2 per axis; the start is 25 degrees (about a random axis) and 0.15 units off.
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0, 1);
  const auto axis = random_unit(rng);
  const Quaternion q_true = axis_angle(axis, 30 + 60 * uniform(rng));
  const std::array<double, 3> t_true{0.4 * uniform(rng) - 0.2, 0.4 * uniform(rng) - 0.2, 0.4 * uniform(rng) - 0.2};
  const Quaternion q_start = multiply(axis_angle(random_unit(rng), 25.0), q_true);
  const auto shift = random_unit(rng);
  const Tensor true_pose = rigid(Tensor::from_values({q_true[0], q_true[1], q_true[2], q_true[3]}, {4}),
                                 Tensor::from_values({t_true[0], t_true[1], t_true[2]}, {3}));
  Tensor q = Tensor::from_values({q_start[0], q_start[1], q_start[2], q_start[3]}, {4}).set_requires_grad();
  Tensor t = Tensor::from_values({t_true[0] + 0.15 * shift[0], t_true[1] + 0.15 * shift[1], t_true[2] + 0.15 * shift[2]},
                                 {3})
                 .set_requires_grad();
  auto posed = [&](const Tensor& pose) { return slice(transform_points(mesh.positions, pose), 1, 0, 3); };
  auto pose_error = [&](double& degrees, double& distance) {
    NoGradGuard no_grad;
    rigid_error(rigid(q, t), true_pose, degrees, distance);
  };

  Render target;
  {
    NoGradGuard no_grad;
    target = render(mesh, posed(true_pose), scene.reference_material, vp, camera.light, scene.background, options.size);
  }
  pose_error(result.initial_rotation_error, result.initial_translation_error);

  Adam optimizer({q, t}, AdamOptions{options.pose_lr});
  Run run(options, iterations, log, result);
  const auto loop_start = Clock::now();
  for (int it = 0; it < iterations; ++it) {
    optimizer.set_lr(options.pose_lr * std::pow(0.1, double(it) / iterations));
    const Render r = render(mesh, posed(rigid(q, t)), scene.reference_material, vp, camera.light, scene.background,
                            options.size);
    if (it == 0) result.initial_iou = coverage_iou(r.coverage, target.coverage);
    const Tensor loss = mean(pow(r.image - target.image, 2.0));
    const double loss_value = loss.item();
    if (!std::isfinite(loss_value)) throw ValueError("fit: the loss became " + std::to_string(loss_value));
    backward(loss);
    optimizer.step();
    optimizer.zero_grad();
    run.snapshot(it, {target.image}, {r.image.detach()});
    run.step_done(it + 1, loss_value);
  }
  const double loop_seconds = seconds_since(loop_start);
  run.finish_loop();

  {
    NoGradGuard no_grad;
    const Render r = render(mesh, posed(rigid(q, t)), scene.reference_material, vp, camera.light, scene.background,
                            options.size);
    result.losses.push_back(mse(r.image, target.image));
    result.final_iou = coverage_iou(r.coverage, target.coverage);
    run.snapshot(iterations, {target.image}, {r.image});
    result.positions = posed(rigid(q, t));
  }
  pose_error(result.final_rotation_error, result.final_translation_error);
  run.write_plot();
  result.files.push_back(in_dir(options.out_dir, "posed.obj"));
  write_mesh(result.files.back(), mesh, result.positions, Tensor(), "");

  result.initial_loss = result.losses.front();
  result.final_loss = result.losses.back();
  result.iterations_per_second = loop_seconds > 0 ? iterations / loop_seconds : 0;
  result.seconds = seconds_since(start);
  return result;
}

}  // namespace

std::vector<int> snapshot_iterations(int iterations) {
  std::vector<int> at{0, iterations / 20, iterations / 5, iterations / 2, iterations};
  std::sort(at.begin(), at.end());
  at.erase(std::unique(at.begin(), at.end()), at.end());
  return at;
}

double coverage_iou(const Tensor& a, const Tensor& b) {
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  if (x.size() != y.size()) throw ShapeError("coverage_iou: masks of different sizes");
  double both = 0, either = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const bool p = x[i] > 0.5, q = y[i] > 0.5;
    both += p && q, either += p || q;
  }
  return either > 0 ? both / either : 1.0;
}

FitResult run_fit(const FitOptions& options, std::ostream& log) {
  if (options.iterations < 0 || options.size < 1) throw ValueError("run_fit: iterations must be >= 0 and size >= 1");
  set_num_threads(options.threads);
  std::filesystem::create_directories(options.out_dir);
  return options.mode == Mode::Pose ? run_pose(options, log) : run_shape(options, log);
}

}  // namespace fit
