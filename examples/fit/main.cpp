// gradraster-fit: the main example (scripts/demo.sh runs it with no
// arguments). Parses flags, runs fit::run_fit, prints a summary.
#include <exception>
#include <iomanip>
#include <iostream>

#include "examples/common/cli_args.h"
#include "examples/fit/cli.h"
#include "examples/fit/fit.h"
#include "examples/fit/fit_outputs.h"
#include "examples/fit/job.h"
#include "examples/fit/option_agreement.h"
#include "examples/fit/progress.h"
#include "examples/fit/snapshot.h"
#include "autodiff/base/parallel.h"
#include "raster/temporaries.h"
#ifdef GRADRASTER_HAS_VULKAN
#include "raster/vulkan/backend.h"
#endif
#ifdef GRADRASTER_FIT_MPI
#include "examples/fit/mpi_main.h"
#endif

namespace {

// The tool on one process, or on one process of an MPI job (job.comm set):
// every process fits its block of views; only the root prints and writes.
int run(int argc, char** argv, const fit::Job& job) {
  const std::string program = argc > 0 ? argv[0] : "gradraster-fit";
  std::ostream& out = job.out;
  fit::CommandLine cl = fit::parse_command_line(std::vector<std::string>(argv + 1, argv + argc));
  if (job.comm) {  // an MPI job: every process must run the same fit, or none starts
    const std::string disagreement = fit::option_disagreement(*job.comm, fit::run_shaping_options(cl));
    if (!disagreement.empty()) {
      if (job.root) std::cerr << program << ": " << disagreement << "\n";
      return 2;
    }
  }
  if (cl.action == fit::CommandLine::Action::Help) {
    out << fit::usage(program);
    return 0;
  }
  if (cl.action == fit::CommandLine::Action::Error) {
    if (job.root) std::cerr << program << ": " << cl.error << "\n\n" << fit::usage(program);
    return 2;
  }
  fit::FitOptions& o = cl.options;
  o.interactive = job.root && fit::stdout_is_terminal();
  o.communicator = job.comm;
  if (job.root) o.warnings = &std::cerr;
  if (job.comm && job.comm->size() > 1 && o.mode == fit::Mode::Pose) {
    if (job.root) std::cerr << program << ": --mode pose fits one view; run it without mpirun\n";
    return 2;
  }
  if (cl.device == "vulkan") {
#ifdef GRADRASTER_HAS_VULKAN
    std::string why;
    std::shared_ptr<gr::vulkan::Device> device = gr::vulkan::Device::open(&why);
    if (!device) {
      if (job.root) std::cerr << program << ": --device vulkan: " << why << "\n";
      return 1;
    }
    o.raster_backend = gr::vulkan::raster_backend(device);
#else
    if (job.root) std::cerr << program << ": --device vulkan: this build has no GPU path (built without Vulkan)\n";
    return 2;
#endif
  }
  const bool pose = o.mode == fit::Mode::Pose;
  const int iterations =
      o.iterations > 0 ? o.iterations : pose ? fit::kDefaultPoseIterations : fit::kDefaultShapeIterations;

  if (pose)
    out << "gradraster-fit --mode pose: recovering the rotation and translation of the object from one\n"
              << o.size << "x" << o.size << " image, starting 25 degrees and 0.15 units off; " << iterations
              << " Adam steps on a quaternion and a translation.\n";
  else
    out << "gradraster-fit: a grey sphere is fitted to " << o.views << " views (" << o.size << "x" << o.size
              << ") of a textured object, " << iterations << " Adam steps.\n"
              << "Fitted: free vertex positions (+ Laplacian smoothness), "
              << (o.appearance == fit::Appearance::Texture ? "a texture" : "vertex colours")
              << (o.fit_camera ? ", a rigid correction per camera" : "")
              << ". The loss is the MSE of colour and alpha mask over all pixels;\nantialiasing gives silhouette edges their gradient.\n";
  if (o.raster_backend) out << "G-buffers on " << o.raster_backend->name() << "\n";
  try {
    if (!job.root) {  // no outputs, no progress: the root has them
      o.write_outputs = false;
      o.progress_bar = false;
    }
    const fit::FitResult r = job.root ? fit::run_fit_with_outputs(o, out) : fit::run_fit(o, out);
    if (!job.root) return 0;
    out << std::setprecision(4) << "\nobject:          " << r.scene_name << " (fitted mesh: " << r.points
              << " points, " << r.triangles << " triangles)\n"
              << "loss:            " << std::scientific << r.initial_loss << " -> " << r.final_loss << std::fixed
              << std::setprecision(1) << "  (" << r.initial_loss / r.final_loss << "x lower)\n"
              << std::setprecision(3) << "silhouette IoU:  " << r.initial_iou << " -> " << r.final_iou
              << (pose ? "\n" : "  (mean over views)\n");
    if (pose || o.fit_camera)
      out << std::setprecision(2) << (pose ? "rotation error:  " : "camera rotation: ") << r.initial_rotation_error
                << " -> " << r.final_rotation_error << " degrees\n"
                << std::setprecision(4) << (pose ? "translation err: " : "camera shift:    ")
                << r.initial_translation_error << " -> " << r.final_translation_error
                << " units (object radius 1)" << (pose ? "\n" : ", mean over views\n");
    out << std::setprecision(1) << "wall time:       " << r.seconds << " s, " << r.iterations_per_second
              << " it/s\n"
              << "outputs:         snapshot_NNNN.png (target | current | |difference| x" << fit::kDifferenceGain
              << (pose ? "" : ", one row per view") << "), loss.png, " << (pose ? "posed.obj" : "fitted.obj")
              << (o.appearance == fit::Appearance::Texture && !pose ? " (+ fitted.mtl, fitted_texture.png)" : "")
              << " in " << o.out_dir << "/\n";
    if (cl.profile) {
      out << "loop, ms per iteration (" << gr::num_threads() << " threads):\n" << std::setprecision(2);
      for (const fit::PhaseTime& p : r.phases)
        out << "  " << std::left << std::setw(34) << p.name << std::right << std::setw(8)
            << 1000 * p.seconds / r.iterations << "\n";
#ifdef GRADRASTER_HAS_VULKAN
      if (o.raster_backend) {
        const gr::vulkan::ResidencyStats g = gr::vulkan::residency_stats(*o.raster_backend);
        out << "G-buffers on the device: " << g.gbuffers << " made, " << g.resident_calls
            << " calls read them there, " << g.uploads << " uploaded from the host, " << g.frames << " frames\n";
      }
#endif
    }
  } catch (const gr::ProcessFailed& e) {  // every process of the job knows: each ends cleanly
    if (job.root || (job.comm && e.failed_rank == job.comm->rank())) std::cerr << program << ": " << e.what() << "\n";
    return 1;
  } catch (const gr::cli::UsageError& e) {  // an output that is an input or another output
    if (job.fail) job.fail(e.what());
    std::cerr << program << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {  // gr::Error (bad mesh, memory, unwritable file) or std::filesystem_error
    if (job.fail) job.fail(e.what());  // an MPI job: end every process, none is left waiting
    std::cerr << program << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  gr::raster::remove_temporaries_on_signals();  // Ctrl-C leaves no staging folder behind
#ifdef GRADRASTER_FIT_MPI
  if (fit::launched_by_mpirun()) return fit::run_mpi_job(argc, argv, run);
#endif
  return run(argc, argv, fit::Job{std::cout, nullptr, true, nullptr});
}
