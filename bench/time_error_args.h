// time_error's command line (issue 30 item 12): --help, whole-word flags,
// unknown arguments refused, scene names checked, and every output file
// named up front so that none is an input or another output
// (examples/common/distinct_files.h) before a sweep of many minutes starts.
//
//   time_error [--scene NAME] [--supersampled-reference] [OUT.csv [OUT.png]]
//   time_error [--scene NAME] --convergence | --soft-consistency
#pragma once

#include <string>
#include <vector>

namespace gr::bench {

struct TimeErrorArgs {
  enum class Action { Sweep, Convergence, SoftConsistency, Help } action = Action::Sweep;
  std::vector<std::string> scenes;  // every scene by default (the studies: the torus)
  bool supersampled_reference = false;
  std::string csv_path = "out/time_error.csv";
  std::string png_path = "out/time_error.png";
};

std::string time_error_usage();

// args excludes the program name. Throws cli::UsageError naming the argument.
TimeErrorArgs parse_time_error_args(const std::vector<std::string>& args);

// The plot of one scene: png_path for the torus, <stem>_<scene>.png beside it for the others.
std::string time_error_plot_path(const std::string& png_path, const std::string& scene);
// The scene's picture (image | target), time_error_scene_<scene>.png beside the plot.
std::string time_error_picture_path(const std::string& png_path, const std::string& scene);

// Throws cli::UsageError if two of the sweep's outputs (the CSV, each
// scene's plot and picture) are the same file.
void check_time_error_outputs(const TimeErrorArgs& args);

}  // namespace gr::bench
