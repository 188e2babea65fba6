// The fit example's core, callable from main() and from tests: inverse
// rendering through the whole differentiable pipeline (rasterize ->
// interpolate -> texture -> Lambert -> antialias), optimized with the
// library's Adam.
//
// Shape mode (the default): target images of a textured reference object from
// several views; the start is a grey sphere. Fitted: free 3-D positions of the
// sphere's points (with a uniform-Laplacian smoothness term and a smoothing
// reparametrization), vertex colours or
// a texture, and optionally a small rigid correction of every camera. The loss
// is the mean squared error over all pixels of the colour and of an alpha mask
// (coverage antialiased like the colour), silhouettes included: the antialias
// op gives the edge vertices their gradient, and the mask keeps it alive where
// the surface's colour matches the background.
//
// Pose mode: one target image of the reference at an unknown rotation and
// translation; starting from a pose about 25 degrees and 0.15 units off, only
// the pose (a quaternion and a translation) is fitted.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <iosfwd>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"
#include "autodiff/view_gradients.h"
#include "examples/fit/phase_times.h"
#include "raster/backend.h"

namespace fit {

enum class Mode { Shape, Pose };
enum class Appearance { Colours, Texture };  // what shape mode fits besides the positions

struct FitOptions {
  Mode mode = Mode::Shape;
  int iterations = 0;              // 0: the mode's default (kDefaultShapeIterations / kDefaultPoseIterations)
  int size = 128;                  // images are size x size
  int views = 6;                   // shape mode (pose mode uses one view)
  std::string out_dir = "out";
  int threads = 0;                 // 0: all hardware threads
  std::string mesh_path;           // empty: the built-in object
  std::string texture_path;        // the reference's texture (overrides the OBJ's map_Kd)
  std::uint64_t seed = 1;          // pose mode: the true pose and the start's error; --fit-camera: camera errors
  Appearance appearance = Appearance::Colours;
  bool fit_camera = false;         // shape mode: start from perturbed cameras and fit a correction per view
  int start_subdivisions = 4;      // start icosphere: 20 * 4^s triangles
  int reference_subdivisions = 0;  // built-in reference icosphere; 0: 5 (shape), 4 (pose renders it every step)
  int texture_size = 128;          // fitted texture: texture_size x 2 texture_size
  // Where the views' G-buffers are made (null: the CPU); the results are the
  // same bits either way (raster/backend.h).
  std::shared_ptr<const gr::raster::RasterBackend> raster_backend = nullptr;
  // Adam learning rates (one parameter group each), decayed geometrically to 10% over the run.
  double position_lr = 0.02;
  double colour_lr = 0.03;
  double camera_lr = 0.003;
  double pose_lr = 0.02;
  double laplacian_weight = 60.0;  // times mean |L x|^2, decayed like the learning rates
  int smoothing_passes = 4;        // positions = start + (I - L/2)^k u (see run_fit)
  bool progress_bar = true;        // print progress (to the stream given to run_fit)
  bool interactive = false;        // redraw one line with '\r' (set it when stdout is a terminal)
  // Optional: called after every optimization step with the steps done and that
  // step's image loss (bench/long_run watches memory with it).
  std::function<void(int done, double loss)> on_step;
  // Shape mode, data parallel (docs/scaling.md): the process group the views
  // are split over (nullptr: this process alone). Results are the same bits
  // for any group size. Only one process should write outputs and print.
  gr::Communicator* communicator = nullptr;
  bool write_outputs = true;  // snapshots, loss plot, fitted mesh
  // Where warnings go, one line each (a missing MTL or texture: the reference
  // then wears the procedural pattern); nullptr: nowhere.
  std::ostream* warnings = nullptr;
};

constexpr int kDefaultShapeIterations = 300;
constexpr int kDefaultPoseIterations = 200;

struct FitResult {
  Mode mode = Mode::Shape;
  std::string scene_name;
  std::int64_t points = 0, triangles = 0;  // of the mesh being fitted
  int iterations = 0;
  std::vector<double> losses;      // image loss before each step, then after the last one
  double initial_loss = 0, final_loss = 0;
  double initial_iou = 0, final_iou = 0;  // silhouette IoU with the targets, mean over views
  double seconds = 0;              // wall time of the whole run
  double iterations_per_second = 0;  // of the optimization loop alone
  // Pose mode, and the camera corrections of --fit-camera (mean over views):
  // rotation error in degrees, translation error in scene units (object radius 1).
  double initial_rotation_error = 0, final_rotation_error = 0;
  double initial_translation_error = 0, final_translation_error = 0;
  gr::Tensor positions;            // shape: fitted points [P, 3]; pose: the posed reference points
  gr::Tensor colours, texture;     // the fitted appearance (one of them)
  std::vector<std::string> files;  // everything written, in order
  std::vector<std::string> inputs;  // the files read: the mesh, its MTL files and its texture, when given
  std::vector<PhaseTime> phases;    // the optimization loop's wall time by phase (--profile prints it)
};

// Runs the optimization, writing PNG strips, a loss plot and the fitted OBJ to
// options.out_dir (created if missing). Progress goes to `log`.
FitResult run_fit(const FitOptions& options, std::ostream& log);

// Iterations at which run_fit writes a snapshot strip (0 and `iterations` included).
std::vector<int> snapshot_iterations(int iterations);

// The names (no folder) of every file run_fit can write with these options:
// snapshot_NNNN.png, loss.png, fitted.obj or posed.obj, fitted.mtl and
// fitted_texture.png.
std::vector<std::string> output_file_names(const FitOptions& options);

// Silhouette IoU of two coverage masks (any shape, 1 = covered): |a and b| / |a or b|.
double coverage_iou(const gr::Tensor& a, const gr::Tensor& b);

}  // namespace fit
