// The fit example's core, callable from main() and from tests: inverse
// rendering of vertex colours and vertex positions from Lambert-shaded target
// images of several views, with Adam and a Laplacian smoothness term.
//
// What is fitted, honestly: the start has the reference's triangles, grey
// colours and positions dented along the normals; the parameters are the
// vertex colours and one offset per vertex along its start normal. There is no antialias op
// yet, so gradients come from pixel interiors only and silhouettes do not
// move; the image loss therefore counts only pixels covered in both the
// target and the current render.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "autodiff/tensor.h"

namespace fit {

struct FitOptions {
  int iterations = 300;
  int size = 128;                  // images are size x size
  int views = 6;
  std::string out_dir = "out";
  int threads = 0;                 // 0: all hardware threads
  std::string mesh_path;           // empty: the built-in object
  std::uint64_t seed = 1;
  double colour_lr = 0.03;         // Adam learning rates, decayed to 10% over the run
  double position_lr = 0.002;
  double laplacian_weight = 5.0;
  bool progress_bar = true;        // print progress (to the stream given to run_fit)
  bool interactive = false;        // redraw one line with '\r' (set it when stdout is a terminal)
};

struct FitResult {
  std::string scene_name;
  std::int64_t vertices = 0, triangles = 0;
  std::vector<double> losses;      // image loss before each step, then after the last one
  double initial_loss = 0, final_loss = 0;
  double seconds = 0;              // wall time of the whole run
  double iterations_per_second = 0;  // of the optimization loop alone
  double start_position_rms = 0, final_position_rms = 0;  // vertex distance to the reference
  double start_colour_rms = 0, final_colour_rms = 0;      // colour distance to the reference
  gr::Tensor positions, colours;   // fitted parameters [N, 3]
  std::vector<std::string> files;  // everything written, in order
};

// Runs the optimization, writing PNG strips, a loss plot and the fitted OBJ to
// options.out_dir (created if missing). Progress and the summary go to `log`.
FitResult run_fit(const FitOptions& options, std::ostream& log);

// Iterations at which run_fit writes a snapshot strip (0 and `iterations` included).
std::vector<int> snapshot_iterations(int iterations);

}  // namespace fit
