// gradraster-fit: the main example (scripts/demo.sh runs it with no
// arguments). Parses flags, runs fit::run_fit, prints a summary.
#include <exception>
#include <iomanip>
#include <iostream>

#include "examples/fit/cli.h"
#include "examples/fit/fit.h"
#include "examples/fit/progress.h"
#include "examples/fit/snapshot.h"

int main(int argc, char** argv) {
  const std::string program = argc > 0 ? argv[0] : "gradraster-fit";
  fit::CommandLine cl = fit::parse_command_line(std::vector<std::string>(argv + 1, argv + argc));
  if (cl.action == fit::CommandLine::Action::Help) {
    std::cout << fit::usage(program);
    return 0;
  }
  if (cl.action == fit::CommandLine::Action::Error) {
    std::cerr << program << ": " << cl.error << "\n\n" << fit::usage(program);
    return 2;
  }
  fit::FitOptions& o = cl.options;
  o.interactive = fit::stdout_is_terminal();

  std::cout << "gradraster-fit: fitting vertex colours and positions to " << o.views << " Lambert-shaded views ("
            << o.size << "x" << o.size << "), " << o.iterations << " Adam steps.\n"
            << "Start: same triangles, grey colours, positions dented along the normals. Fitted: vertex\n"
            << "colours and one offset per vertex along its normal. Without antialiasing, silhouettes\n"
            << "get no gradient: the image loss counts pixels covered in both target and render.\n";
  try {
    const fit::FitResult r = fit::run_fit(o, std::cout);
    std::cout << std::setprecision(4) << "\nobject:        " << r.scene_name << " (" << r.vertices << " vertices, "
              << r.triangles << " triangles)\n"
              << "image loss:    " << std::scientific << r.initial_loss << " -> " << r.final_loss << std::fixed
              << std::setprecision(1) << "  (" << r.initial_loss / r.final_loss << "x lower)\n"
              << std::setprecision(4) << "colour RMS:    " << r.start_colour_rms << " -> " << r.final_colour_rms
              << "  (per vertex, vs the reference)\n"
              << "position RMS:  " << r.start_position_rms << " -> " << r.final_position_rms
              << "  (per vertex, object radius 1)\n"
              << std::setprecision(1) << "wall time:     " << r.seconds << " s, " << r.iterations_per_second
              << " it/s\n"
              << "outputs:       snapshot_NNNN.png (target | current | |difference| x" << fit::kDifferenceGain
              << ", one row per view), loss.png, fitted.obj in " << o.out_dir << "/\n";
  } catch (const std::exception& e) {  // gr::Error (bad mesh, unwritable file) or std::filesystem_error
    std::cerr << program << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}
