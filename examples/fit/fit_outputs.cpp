#include "examples/fit/fit_outputs.h"

#include <algorithm>
#include <filesystem>
#include <new>

#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "examples/common/cli_args.h"
#include "examples/common/distinct_files.h"
#include "examples/common/output_folder.h"
#include "raster/io/files.h"
#include "raster/temporaries.h"

namespace fit {
namespace fs = std::filesystem;

std::size_t fit_request_bytes(const FitOptions& o) {
  const std::size_t views = o.mode == Mode::Pose ? 1 : static_cast<std::size_t>(o.views);
  const auto pixels = static_cast<std::size_t>(o.size) * static_cast<std::size_t>(o.size);
  return 288 * pixels * views + (std::size_t(16) << 20);
}

namespace {

// Every file the run may write in options.out_dir, named for messages.
std::vector<gr::cli::NamedFile> planned_outputs(const FitOptions& options) {
  std::vector<gr::cli::NamedFile> outputs;
  for (const std::string& name : output_file_names(options))
    outputs.push_back({"--out '" + options.out_dir + "' (its " + name + ")",
                       (fs::path(options.out_dir) / name).string()});
  return outputs;
}

std::vector<gr::cli::NamedFile> named_inputs(const std::vector<std::string>& paths) {
  std::vector<gr::cli::NamedFile> inputs;
  for (const std::string& p : paths) inputs.push_back({"the input", p});
  return inputs;
}

}  // namespace

FitResult run_fit_with_outputs(const FitOptions& options, std::ostream& log) {
  // No output may replace an input: first the ones on the command line...
  const std::vector<gr::cli::NamedFile> outputs = planned_outputs(options);
  gr::cli::check_distinct_files({{"--mesh", options.mesh_path}, {"--texture", options.texture_path}}, outputs);

  const std::size_t estimate = fit_request_bytes(options);
  const std::string request = "gradraster-fit --size " + std::to_string(options.size) + " with " +
                              std::to_string(options.mode == Mode::Pose ? 1 : options.views) + " views";
  gr::check_memory_request(estimate, request);
  log << "memory estimate: " << gr::cli::mib(estimate) << " (limit " << gr::cli::mib(gr::memory_limit()) << ")\n";

  gr::cli::OutputFolder folder(options.out_dir);
  folder.create();
  gr::raster::remove_stale_temporaries(options.out_dir);  // staging folders of killed runs
  FitOptions staged = options;
  staged.out_dir = (fs::path(options.out_dir) / gr::raster::staging_folder_name()).string();
  // Removes the staging folder whatever happens: on return, on an exception
  // and on a signal (the registration).
  struct Cleanup {
    std::string path;
    gr::raster::TemporaryRegistration registration{path, gr::raster::TemporaryKind::Folder};
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } cleanup{staged.out_dir};

  FitResult result;
  try {
    result = run_fit(staged, log);
  } catch (const std::bad_alloc&) {
    throw gr::MemoryError("out of memory during " + request);
  }
  // ...then every file the run read (the texture an MTL names), before any rename.
  gr::cli::check_distinct_files(named_inputs(result.inputs), outputs);
  // Every file first, then the renames: a bad target moves nothing.
  const std::vector<std::string> planned = output_file_names(options);
  std::vector<std::string> targets;
  for (const std::string& file : result.files) {
    const std::string name = fs::path(file).filename().string();
    if (std::find(planned.begin(), planned.end(), name) == planned.end())
      throw gr::Error("internal error: gradraster-fit wrote " + name + ", which output_file_names does not list");
    targets.push_back((fs::path(options.out_dir) / name).string());
    gr::raster::check_output_target(targets.back());
  }
  for (std::size_t i = 0; i < targets.size(); ++i) fs::rename(result.files[i], targets[i]);
  result.files = targets;
  folder.keep();
  return result;
}

}  // namespace fit
