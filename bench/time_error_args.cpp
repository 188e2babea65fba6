#include "bench/time_error_args.h"

#include <algorithm>
#include <filesystem>

#include "bench/time_error_scene.h"
#include "examples/common/cli_args.h"
#include "examples/common/distinct_files.h"

namespace gr::bench {
namespace fs = std::filesystem;

std::string time_error_usage() {
  return R"(Usage: time_error [--scene NAME] [--supersampled-reference] [OUT.csv [OUT.png]]
       time_error [--scene NAME] --convergence | --soft-consistency

Run time against gradient error of the dtype / antialias / supersampling / soft
rasterization choices on four fixed scenes (docs/time_error.md); takes minutes.

  --scene NAME               one scene: torus, intersection, occlusion or open_culled
                             (default: all four in sequence; the studies: torus)
  --supersampled-reference   grade against a 16x16 supersampled render instead of the
                             exact box-filtered image
  OUT.csv                    the table of every configuration (default out/time_error.csv)
  OUT.png                    the torus' plot (default out/time_error.png); another scene's
                             goes to OUT_<scene>.png, each scene's picture to
                             time_error_scene_<scene>.png beside it
  --convergence              the supersampled reference's convergence study (slow; prints only)
  --soft-consistency         soft rasterization's gradient against FD of its own loss (prints only)
  --help                     this text

Exit codes: 0 success, 1 runtime error, 2 usage error (nothing runs).
)";
}

TimeErrorArgs parse_time_error_args(const std::vector<std::string>& args) {
  TimeErrorArgs a;
  std::vector<std::string> positional;
  bool scene_given = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      a.action = TimeErrorArgs::Action::Help;
      return a;
    }
    if (arg == "--scene") {
      if (scene_given) cli::fail(arg, "given more than once");
      if (i + 1 >= args.size()) cli::fail(arg, "missing value");
      const std::string& name = args[++i];
      const std::vector<std::string>& names = time_error_scene_names();
      if (std::find(names.begin(), names.end(), name) == names.end())
        cli::fail(arg, "expected torus, intersection, occlusion or open_culled, got " + cli::quoted(name));
      a.scenes = {name};
      scene_given = true;
    } else if (arg == "--supersampled-reference") {
      if (a.supersampled_reference) cli::fail(arg, "given more than once");
      a.supersampled_reference = true;
    } else if (arg == "--convergence" || arg == "--soft-consistency") {
      if (a.action != TimeErrorArgs::Action::Sweep) cli::fail(arg, "give only one of --convergence and --soft-consistency");
      a.action = arg == "--convergence" ? TimeErrorArgs::Action::Convergence : TimeErrorArgs::Action::SoftConsistency;
    } else if (arg.rfind("-", 0) == 0) {
      throw cli::UsageError("unknown option " + cli::quoted(arg));
    } else {
      positional.push_back(arg);
    }
  }
  if (positional.size() > 2) throw cli::UsageError("unexpected argument " + cli::quoted(positional[2]));
  if (a.action != TimeErrorArgs::Action::Sweep) {
    const std::string study = a.action == TimeErrorArgs::Action::Convergence ? "--convergence" : "--soft-consistency";
    if (!positional.empty()) cli::fail(study, "prints only; it takes no output file, got " + cli::quoted(positional[0]));
    if (a.supersampled_reference) cli::fail("--supersampled-reference", "applies only to the sweep, not " + study);
    if (!scene_given) a.scenes = {"torus"};
    return a;
  }
  if (!scene_given) a.scenes = time_error_scene_names();
  if (!positional.empty()) a.csv_path = positional[0];
  if (positional.size() > 1) a.png_path = positional[1];
  return a;
}

std::string time_error_plot_path(const std::string& png_path, const std::string& scene) {
  if (scene == "torus") return png_path;
  const fs::path p(png_path);
  return (p.parent_path() / (p.stem().string() + "_" + scene + p.extension().string())).string();
}

std::string time_error_picture_path(const std::string& png_path, const std::string& scene) {
  return (fs::path(time_error_plot_path(png_path, scene)).parent_path() / ("time_error_scene_" + scene + ".png"))
      .string();
}

void check_time_error_outputs(const TimeErrorArgs& a) {
  std::vector<cli::NamedFile> outputs{{"OUT.csv", a.csv_path}};
  for (const std::string& scene : a.scenes) {
    outputs.push_back({"the " + scene + " plot", time_error_plot_path(a.png_path, scene)});
    outputs.push_back({"the " + scene + " picture", time_error_picture_path(a.png_path, scene)});
  }
  cli::check_distinct_files({}, outputs);
}

}  // namespace gr::bench
