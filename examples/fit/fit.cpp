// run_fit: builds the scene, renders the targets, then loops
// render -> loss -> backward -> Adam, writing snapshots along the way.
#include "examples/fit/fit.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <ostream>
#include <random>

#include "autodiff/base/error.h"
#include "autodiff/optim.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "autodiff/view_gradients.h"
#include "examples/fit/concurrent_views.h"
#include "examples/fit/geometry.h"
#include "examples/fit/plot.h"
#include "examples/fit/progress.h"
#include "examples/fit/scene.h"
#include "examples/fit/shading.h"
#include "examples/fit/snapshot.h"
#include "examples/fit/snapshot_writer.h"
#include "ops/ops.h"
#include "raster/io/image_io.h"
#include "raster/io/obj_io.h"

namespace fit {

using namespace gr;

namespace {

// The views' rasterize options: size x size, on the chosen backend.
RasterizeOptions raster_options(const FitOptions& options) {
  RasterizeOptions raster{options.size, options.size};
  raster.backend = options.raster_backend;
  return raster;
}

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string in_dir(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

std::string snapshot_name(int iteration) {
  char name[64];
  std::snprintf(name, sizeof name, "snapshot_%04d.png", iteration);
  return name;
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

  bool wants_snapshot(int iteration) const {
    return options_.write_outputs && std::binary_search(snapshots_.begin(), snapshots_.end(), iteration);
  }
  void snapshot(int iteration, const std::vector<Tensor>& targets, const std::vector<Tensor>& current) {
    if (!wants_snapshot(iteration)) return;
    result_.files.push_back(in_dir(options_.out_dir, snapshot_name(iteration)));
    writer_.write(result_.files.back(), targets, current);
  }
  void step_done(int done, double loss) {
    result_.losses.push_back(loss);
    if (options_.progress_bar) progress_.update(done, loss);
    if (options_.on_step) options_.on_step(done, loss);
  }
  void finish_loop() {
    if (options_.progress_bar) progress_.finish();
  }
  // Waits for the snapshots (the last one included) and writes the loss plot.
  void finish_outputs() {
    writer_.finish();
    if (!options_.write_outputs) return;
    result_.files.push_back(in_dir(options_.out_dir, "loss.png"));
    raster::write_png(result_.files.back(), plot_loss_curve(result_.losses));
  }

 private:
  const FitOptions& options_;
  FitResult& result_;
  std::vector<int> snapshots_;
  ProgressBar progress_;
  SnapshotWriter writer_;  // snapshots are written beside the loop
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

// ---- run_shape, phase by phase ----

Scene shape_scene(const FitOptions& options) {
  SceneOptions scene_options;
  scene_options.views = options.views;
  scene_options.mesh_path = options.mesh_path;
  scene_options.texture_path = options.texture_path;
  scene_options.reference_subdivisions = options.reference_subdivisions > 0 ? options.reference_subdivisions : 5;
  scene_options.start_subdivisions = options.start_subdivisions;
  return make_scene(scene_options);
}

// What every view of the reference looks like: colour, coverage and alpha.
struct Targets {
  std::vector<Tensor> images, coverage, rgba;
};

Targets render_targets(const Scene& scene, const RasterizeOptions& raster) {
  NoGradGuard no_grad;
  Targets targets;
  for (const Camera& camera : scene.cameras) {
    const Render r = render(scene.reference, scene.reference.positions, scene.reference_material,
                            matmul(camera.projection, camera.view), camera.light, scene.background, raster);
    targets.images.push_back(r.image());
    targets.coverage.push_back(r.coverage);
    targets.rgba.push_back(r.rgba);
  }
  return targets;
}

// Positions are free 3-D points: start + S^k(u) with one offset u per point
// and S = I + L/2 (L x = the neighbours' mean - x: a half step towards it), k =
// smoothing_passes. S^k is invertible, so any positions can be reached, but a
// gradient on one vertex moves its neighbourhood: a cheap stand-in for the
// "large steps" preconditioner of Nicolet et al. 2021. Without it (k = 0) the
// silhouette gradients, which reach only edge vertices, pull single vertices
// into spikes and folds (measured: IoU 0.96 and a crumpled waist vs 0.99).
class SmoothedPositions {
 public:
  SmoothedPositions(const SurfaceMesh& mesh, int passes)
      : offsets(Tensor::zeros({mesh.num_points(), 3}).set_requires_grad()),
        laplacian(mesh.point_triangles, mesh.num_points()),
        mesh_(mesh),
        passes_(passes) {}

  Tensor evaluate() const {
    // x <- x + L(x) / 2, passes_ times, as one op (the composite's bits).
    return mesh_.positions + laplacian.smooth(offsets, passes_, 0.5);
  }

  Tensor offsets;  // the parameter u
  const MeshLaplacian laplacian;  // uniform

 private:
  const SurfaceMesh& mesh_;
  int passes_;
};

// Vertex colours or a texture, starting grey; `parameter` is what Adam fits.
struct FittedAppearance {
  Tensor parameter;
  Material material;
};

FittedAppearance grey_appearance(const FitOptions& options, const SurfaceMesh& mesh) {
  FittedAppearance a;
  if (options.appearance == Appearance::Texture) {
    a.parameter = Tensor::full({options.texture_size, 2 * options.texture_size, 3}, 0.5).set_requires_grad();
    a.material.texture = a.parameter;
  } else {
    a.parameter = Tensor::full({mesh.num_points(), 3}, 0.5).set_requires_grad();
    a.material.point_colours = a.parameter;
  }
  return a;
}

// --fit-camera: every camera starts off by a random rigid error in view space
// (about 2 degrees and 0.03 units), and a correction (q, t) per view is fitted:
// view = (translate(t) rotate(q)) * error * true view. Without the flag the
// cameras are exact and nothing is fitted.
class CameraCorrections {
 public:
  CameraCorrections(const FitOptions& options, const Scene& scene) : scene_(scene) {
    if (!options.fit_camera) return;
    std::mt19937_64 rng(options.seed);
    for (std::size_t v = 0; v < scene.cameras.size(); ++v) {
      const Quaternion qe = axis_angle(random_unit(rng), 2.0);
      const auto te = random_unit(rng);
      errors_.push_back(rigid(Tensor::from_values({qe[0], qe[1], qe[2], qe[3]}, {4}),
                              Tensor::from_values({0.03 * te[0], 0.03 * te[1], 0.03 * te[2]}, {3})));
      q_.push_back(Tensor::from_values({1, 0, 0, 0}, {4}).set_requires_grad());
      t_.push_back(Tensor::zeros({3}).set_requires_grad());
    }
  }

  bool fitted() const { return !errors_.empty(); }

  std::vector<Tensor> parameters() const {
    std::vector<Tensor> p;
    for (std::size_t v = 0; v < q_.size(); ++v) p.insert(p.end(), {q_[v], t_[v]});
    return p;
  }

  Tensor view_projection(std::size_t v) const {
    return fitted() ? view_projection(v, q_[v], t_[v]) : view_projection(v, Tensor(), Tensor());
  }
  // With the correction (q, t) given: a view's aliases of q_[v] and t_[v] (ViewGradients::view_leaves).
  Tensor view_projection(std::size_t v, const Tensor& q, const Tensor& t) const {
    const Camera& c = scene_.cameras[v];
    if (!fitted()) return matmul(c.projection, c.view);
    return matmul(c.projection, matmul(rigid(q, t), matmul(errors_[v], c.view)));
  }

  // Mean over views of what remains of the error after the correction.
  void mean_error(double& degrees, double& distance) const {
    NoGradGuard no_grad;
    const std::size_t views = errors_.size();
    degrees = distance = 0;
    for (std::size_t v = 0; v < views; ++v) {
      double d, t;
      rigid_error(matmul(rigid(q_[v], t_[v]), errors_[v]), identity4(), d, t);
      degrees += d / views, distance += t / views;
    }
  }

 private:
  const Scene& scene_;
  std::vector<Tensor> errors_, q_, t_;
};

// One view's part of the loss (the per-pixel colour MSE plus alpha-mask MSE,
// divided by the number of views), its image and its silhouette IoU (only when
// asked: it is logged once).
struct ViewLoss {
  Tensor loss;
  Tensor image;
  double iou = 0;
};

// The image only when asked (for a snapshot).
ViewLoss render_view(const Scene& scene, const Targets& targets, const Surface& surface,
                     const Tensor& view_projection, const RasterizeOptions& raster, std::size_t v, bool with_iou,
                     bool with_image) {
  const Render r = render(scene.start, surface, view_projection, scene.cameras[v].light, scene.background, raster);
  // Colour MSE plus the alpha masks' MSE: a flap of the surface that takes
  // the background's colour is invisible to the first term, not the second.
  const double views = double(scene.cameras.size());
  ViewLoss out;
  out.loss = colour_and_alpha_mse(r.rgba, targets.rgba[v]) / views;
  if (with_image) out.image = r.image().detach();
  if (with_iou) out.iou = coverage_iou(r.coverage, targets.coverage[v]) / views;
  return out;
}

// Every view without gradients, concurrently: the loss (summed in view order
// in float64, as ViewGradients sums it), the images and the mean silhouette IoU.
struct ViewsLoss {
  double loss = 0;
  std::vector<Tensor> images;
  double iou = 0;
};

ViewsLoss render_views(const Scene& scene, const Targets& targets, const Tensor& positions, const Material& material,
                       const CameraCorrections& cameras, const RasterizeOptions& raster) {
  NoGradGuard no_grad;
  const Surface shared = surface(scene.start, positions, material);
  const int views = static_cast<int>(scene.cameras.size());
  std::vector<ViewLoss> each(static_cast<std::size_t>(views));
  parallel_tasks(views, [&](int v) {
    NoGradGuard no_grad_here;  // grad mode is per thread
    each[v] = render_view(scene, targets, shared, cameras.view_projection(v), raster, v, true, true);
  });
  ViewsLoss out;
  for (const ViewLoss& view : each) {
    out.loss += view.loss.item();
    out.images.push_back(view.image);
    out.iou += view.iou;
  }
  return out;
}

// The test hook of the fault test (tests/mpi): GRADRASTER_FIT_FAIL_RANK=R makes
// process R throw in its first view, as bad input on one rank would.
void fail_if_asked(const Communicator& comm) {
  const char* rank = std::getenv("GRADRASTER_FIT_FAIL_RANK");
  if (rank && std::to_string(comm.rank()) == rank)
    throw ValueError("fit: process " + std::to_string(comm.rank()) + " was asked to fail (GRADRASTER_FIT_FAIL_RANK)");
}

// Writes fitted.obj (with fitted.mtl and fitted_texture.png for a texture).
void write_fitted_mesh(const FitOptions& options, const SurfaceMesh& mesh, const Tensor& positions,
                       const Material& material, FitResult& result) {
  result.files.push_back(in_dir(options.out_dir, "fitted.obj"));
  const std::string texture_file = in_dir(options.out_dir, "fitted_texture.png");
  write_mesh(result.files.back(), mesh, positions, material.texture, texture_file);
  if (material.texture.defined()) {
    result.files.push_back(in_dir(options.out_dir, "fitted.mtl"));
    result.files.push_back(texture_file);
  }
}

// A result that names the run; the fit fills in the numbers.
FitResult describe_run(Mode mode, const Scene& scene, const SurfaceMesh& mesh, int iterations) {
  FitResult result;
  result.mode = mode;
  result.scene_name = scene.name;
  result.points = mesh.num_points();
  result.triangles = mesh.num_triangles();
  result.iterations = iterations;
  result.inputs = scene.files_read;
  return result;
}

void report_warnings(const FitOptions& options, const Scene& scene) {
  if (!options.warnings) return;
  for (const std::string& w : scene.warnings) *options.warnings << "gradraster-fit: warning: " << w << "\n";
  options.warnings->flush();
}

FitResult run_shape(const FitOptions& options, std::ostream& log) {
  const auto start = Clock::now();
  const int iterations = options.iterations > 0 ? options.iterations : kDefaultShapeIterations;
  const Scene scene = shape_scene(options);
  report_warnings(options, scene);
  const SurfaceMesh& mesh = scene.start;

  FitResult result = describe_run(Mode::Shape, scene, mesh, iterations);

  const RasterizeOptions raster = raster_options(options);
  const Targets targets = render_targets(scene, raster);
  const SmoothedPositions smoothed(mesh, options.smoothing_passes);
  const FittedAppearance appearance = grey_appearance(options, mesh);
  const CameraCorrections cameras(options, scene);
  if (cameras.fitted()) cameras.mean_error(result.initial_rotation_error, result.initial_translation_error);

  // One optimizer, one parameter group per kind of unknown (the cameras' group only with --fit-camera).
  std::vector<AdamGroup> groups{{{smoothed.offsets}, AdamOptions{options.position_lr}},
                                {{appearance.parameter}, AdamOptions{options.colour_lr}}};
  if (cameras.fitted()) groups.push_back({cameras.parameters(), AdamOptions{options.camera_lr}});
  Adam adam(groups);

  // Data parallel over views, within a process and across processes (MPI):
  // each process renders its block of views, concurrently, each view on its
  // own thread and tape from its own aliases of the shared surface's leaves;
  // ViewGradients then sums every view's gradients in view order on every
  // process, so all of them take the same Adam step and the run is
  // bit-identical for any thread and process count (docs/scaling.md,
  // docs/performance.md).
  SingleProcess single_process;
  Communicator& comm = options.communicator ? *options.communicator : single_process;
  const int views = static_cast<int>(scene.cameras.size());
  const ViewRange mine = views_of_rank(views, comm.rank(), comm.size());
  SharedSurface shared(mesh, appearance.material);
  std::vector<Tensor> view_params = shared.leaves();
  for (const Tensor& c : cameras.parameters()) view_params.push_back(c);
  ViewGradients view_grads(view_params, views, 2);  // values per view: loss, IoU
  // View v's camera correction among its leaves (after the surface's three).
  auto view_projection = [&](int v, const std::vector<Tensor>& leaves) {
    return cameras.fitted() ? cameras.view_projection(v, leaves[3 + 2 * v], leaves[4 + 2 * v])
                            : cameras.view_projection(v);
  };

  ViewSchedule schedule(mine);

  Run run(options, iterations, log, result);
  const auto loop_start = Clock::now();
  PhaseTimes phases;
  phases.start();
  for (int it = 0; it < iterations; ++it) {
    // Learning rates and the Laplacian weight decay geometrically to 10% at the end.
    const double decay = std::pow(0.1, double(it) / iterations);
    for (std::size_t g = 0; g < groups.size(); ++g) adam.set_lr(g, groups[g].options.lr * decay);

    const Tensor positions = smoothed.evaluate();
    shared.update(positions);
    phases.mark("positions, normals, gathers");

    std::vector<Tensor> images(static_cast<std::size_t>(views));
    const double penalty_weight = options.laplacian_weight * decay;
    Tensor penalty_grad;  // d(penalty_weight * penalty)/d positions
    std::exception_ptr failure;  // every process must reach the reduction, failed or not
    try {
      if (it == 0 && mine.begin < mine.end) fail_if_asked(comm);
      // The views, then the Laplacian penalty's gradient: it needs no view,
      // so it runs beside them instead of after them.
      const int my_views = mine.end - mine.begin;
      parallel_tasks(my_views + 1, [&](int i) {
        if (i == my_views) {
          penalty_grad = penalty_gradient(smoothed.laplacian, positions, penalty_weight);
          return;
        }
        const int v = schedule.view(i);
        const auto view_start = Clock::now();
        ScopedTape tape;
        const std::vector<Tensor> leaves = view_grads.view_leaves();
        const ViewLoss view = render_view(scene, targets, shared.as_surface(leaves), view_projection(v, leaves),
                                          raster, v, it == 0, run.wants_snapshot(it));
        backward(view.loss);
        view_grads.take(v, leaves, {view.loss.item(), view.iou});
        images[v] = view.image;
        schedule.took(v, seconds_since(view_start));
      });
      schedule.reorder();
    } catch (...) {
      failure = std::current_exception();
    }
    phases.mark("views (render, loss, backward)");
    raise_if_any_failed(comm, failure);
    const std::vector<double> totals = view_grads.reduce(comm);  // loss, IoU
    const double loss_value = totals[0];
    if (it == 0) result.initial_iou = totals[1];
    if (!std::isfinite(loss_value)) throw ValueError("fit: the loss became " + std::to_string(loss_value));
    phases.mark("reduce (view order)");

    if (run.wants_snapshot(it)) {  // this process rendered only its own views
      NoGradGuard no_grad;
      const Surface now = shared.as_surface(shared.leaves());
      for (int v = 0; v < views; ++v)
        if (!images[v].defined())
          images[v] = render_view(scene, targets, now, cameras.view_projection(v), raster, v, false, true).image;
      run.snapshot(it, targets.images, images);
    }
    phases.mark("snapshots (hand-off)");

    // The views' gradient and the Laplacian term, once: d/d offsets of
    // <positions, dP/dpositions> + <surface(positions), dL/dsurface> (both
    // gradients held constant), P = penalty_weight penalty(positions).
    // One linear form (the composite sum(positions * penalty_grad) + the
    // surface's sums gave the same gradients through products and broadcasts).
    std::vector<Tensor> values{positions}, weights{penalty_grad};
    shared.add_pullback(values, weights);
    backward(sum_of_products(values, weights));
    shared.zero_grad();
    phases.mark("Laplacian, smoothing, normals backward");
    adam.step();
    adam.zero_grad();
    phases.mark("Adam");
    run.step_done(it + 1, loss_value);
    phases.mark("progress");
  }
  const double loop_seconds = seconds_since(loop_start);
  result.phases = phases.phases();
  run.finish_loop();

  // Final state: one more render of every view without gradient.
  Tensor positions;
  {
    NoGradGuard no_grad;
    positions = smoothed.evaluate();
    const ViewsLoss final_views = render_views(scene, targets, positions, appearance.material, cameras, raster);
    result.losses.push_back(final_views.loss);
    result.final_iou = final_views.iou;
    run.snapshot(iterations, targets.images, final_views.images);
  }
  if (cameras.fitted()) cameras.mean_error(result.final_rotation_error, result.final_translation_error);
  run.finish_outputs();
  if (options.write_outputs) write_fitted_mesh(options, mesh, positions, appearance.material, result);

  result.positions = positions.detach();
  (options.appearance == Appearance::Texture ? result.texture : result.colours) = appearance.parameter.detach();
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
  report_warnings(options, scene);
  const SurfaceMesh& mesh = scene.reference;
  const Camera& camera = scene.cameras[0];
  const Tensor vp = matmul(camera.projection, camera.view);

  FitResult result = describe_run(Mode::Pose, scene, mesh, iterations);

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

  const RasterizeOptions raster = raster_options(options);
  Render target;
  {
    NoGradGuard no_grad;
    target = render(mesh, posed(true_pose), scene.reference_material, vp, camera.light, scene.background, raster);
  }
  pose_error(result.initial_rotation_error, result.initial_translation_error);

  const Tensor target_image = target.image();
  Adam optimizer({q, t}, AdamOptions{options.pose_lr});
  Run run(options, iterations, log, result);
  const auto loop_start = Clock::now();
  for (int it = 0; it < iterations; ++it) {
    optimizer.set_lr(options.pose_lr * std::pow(0.1, double(it) / iterations));
    const Render r = render(mesh, posed(rigid(q, t)), scene.reference_material, vp, camera.light, scene.background,
                            raster);
    if (it == 0) result.initial_iou = coverage_iou(r.coverage, target.coverage);
    const Tensor image = r.image();
    const Tensor loss = mean(pow(image - target_image, 2.0));
    const double loss_value = loss.item();
    if (!std::isfinite(loss_value)) throw ValueError("fit: the loss became " + std::to_string(loss_value));
    backward(loss);
    optimizer.step();
    optimizer.zero_grad();
    run.snapshot(it, {target_image}, {image.detach()});
    run.step_done(it + 1, loss_value);
  }
  const double loop_seconds = seconds_since(loop_start);
  run.finish_loop();

  {
    NoGradGuard no_grad;
    const Render r = render(mesh, posed(rigid(q, t)), scene.reference_material, vp, camera.light, scene.background,
                            raster);
    result.losses.push_back(mse(r.image(), target_image));
    result.final_iou = coverage_iou(r.coverage, target.coverage);
    run.snapshot(iterations, {target_image}, {r.image()});
    result.positions = posed(rigid(q, t));
  }
  pose_error(result.final_rotation_error, result.final_translation_error);
  run.finish_outputs();
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

std::vector<std::string> output_file_names(const FitOptions& options) {
  const bool pose = options.mode == Mode::Pose;
  const int iterations =
      options.iterations > 0 ? options.iterations : pose ? kDefaultPoseIterations : kDefaultShapeIterations;
  std::vector<std::string> names;
  for (int it : snapshot_iterations(iterations)) names.push_back(snapshot_name(it));
  names.push_back("loss.png");
  names.push_back(pose ? "posed.obj" : "fitted.obj");
  if (!pose && options.appearance == Appearance::Texture) {
    names.push_back("fitted.mtl");
    names.push_back("fitted_texture.png");
  }
  return names;
}

namespace {

// Pixels covered in both masks and in either (counts: exact in any order).
struct OverlapCounts {
  std::int64_t both = 0, either = 0;
  explicit OverlapCounts(int = 0) {}
  OverlapCounts& operator+=(const OverlapCounts& o) {
    both += o.both, either += o.either;
    return *this;
  }
};

}  // namespace

double coverage_iou(const Tensor& a, const Tensor& b) {
  if (a.numel() != b.numel()) throw ShapeError("coverage_iou: masks of different sizes");
  NoGradGuard no_grad;
  const Tensor fa = cast(a, DType::Float32), fb = cast(b, DType::Float32);  // no copy when float32 already
  const float* x = fa.data<float>();
  const float* y = fb.data<float>();
  const OverlapCounts n = deterministic_sum<OverlapCounts>(a.numel(), 1 << 14, [&](std::int64_t lo, std::int64_t hi) {
    OverlapCounts c;
    for (std::int64_t i = lo; i < hi; ++i) {
      const bool p = x[i] > 0.5f, q = y[i] > 0.5f;
      c.both += p && q, c.either += p || q;
    }
    return c;
  });
  return n.either > 0 ? double(n.both) / double(n.either) : 1.0;
}

FitResult run_fit(const FitOptions& options, std::ostream& log) {
  if (options.iterations < 0 || options.size < 1) throw ValueError("run_fit: iterations must be >= 0 and size >= 1");
  set_num_threads(options.threads);
  if (options.write_outputs) std::filesystem::create_directories(options.out_dir);
  return options.mode == Mode::Pose ? run_pose(options, log) : run_shape(options, log);
}

}  // namespace fit
