// long_run: the inverse-rendering example (examples/fit, shape mode) for 1000
// optimization steps at a small size (issue 7): every loss and the fitted
// parameters must stay finite, and memory must stay flat. At steps 10, 100,
// 500 and the last one it prints the resident set size (VmRSS) and its peak
// (VmHWM) from /proc/self/status, and the storage cache's fresh allocations
// (gr::storage_stats()). Exit code 1 if a loss or parameter became non-finite
// or RSS grew by more than 10% (and 8 MiB) from step 100 to the last step.
//
//   build/bench/long_run [--iterations 1000] [--size 64] [--views 2] [--subdivisions 3] [--threads N]
//                        [--texture] [--fit-camera]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/base/storage.h"
#include "examples/common/cli_args.h"
#include "examples/fit/fit.h"

namespace {

// VmRSS and VmHWM of this process in KiB (0 if /proc is unavailable).
struct Memory {
  long rss_kib = 0, peak_kib = 0;
};

Memory read_memory() {
  Memory m;
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) m.rss_kib = std::atol(line.c_str() + 6);
    if (line.rfind("VmHWM:", 0) == 0) m.peak_kib = std::atol(line.c_str() + 6);
  }
  return m;
}

struct Checkpoint {
  int step = 0;
  Memory memory;
  std::int64_t fresh_allocations = 0;
  double loss = 0;
  double seconds = 0;
};

bool all_finite(const gr::Tensor& t) {
  if (!t.defined()) return true;
  for (double x : t.to_vector())
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  fit::FitOptions options;
  options.iterations = 1000;
  options.size = 64;
  options.views = 2;
  options.start_subdivisions = 3;
  options.reference_subdivisions = 3;
  options.progress_bar = false;
  const char* usage =
      "Usage: long_run [--iterations N] [--size S] [--views V] [--subdivisions K] [--threads T] [--texture]\n"
      "                [--fit-camera]\n"
      "Runs the fit example for N steps (default 1000) and checks losses, parameters and memory\n"
      "(docs/robustness.md, \"Long run\"). Exit codes: 0 pass, 1 fail, 2 usage error.\n";
  gr::cli::parse_flags_or_exit(
      "long_run", usage, argc, argv,
      {{"--iterations", "--size", "--views", "--subdivisions", "--threads"}, {"--texture", "--fit-camera"}},
      [&](const std::string& flag, const std::string& v) {
        using gr::cli::parse_int;
        if (flag == "--texture") options.appearance = fit::Appearance::Texture;
        else if (flag == "--fit-camera") options.fit_camera = true;
        else if (flag == "--iterations") options.iterations = parse_int(flag, v, 1, 1000000);
        else if (flag == "--size") options.size = parse_int(flag, v, 16, 4096);
        else if (flag == "--views") options.views = parse_int(flag, v, 1, 64);
        else if (flag == "--subdivisions") options.start_subdivisions = parse_int(flag, v, 0, 6);
        else options.threads = parse_int(flag, v, 0, 1024);
      });
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("gradraster_long_run_" + std::to_string(::getpid()));
  options.out_dir = out.string();

  std::vector<int> at = {10, 100, 500, options.iterations};
  std::vector<Checkpoint> checkpoints;
  bool losses_finite = true;
  const auto start = std::chrono::steady_clock::now();
  options.on_step = [&](int done, double loss) {
    losses_finite = losses_finite && std::isfinite(loss);
    for (int a : at)
      if (a == done) {
        Checkpoint c;
        c.step = done;
        c.memory = read_memory();
        c.fresh_allocations = gr::storage_stats().fresh_allocations;
        c.loss = loss;
        c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        checkpoints.push_back(c);
        std::printf("step %5d  loss %.6f  RSS %7.1f MiB  peak RSS %7.1f MiB  fresh allocations %8lld  %6.1f s\n",
                    done, loss, c.memory.rss_kib / 1024.0, c.memory.peak_kib / 1024.0,
                    static_cast<long long>(c.fresh_allocations), c.seconds);
        std::fflush(stdout);
        break;
      }
  };

  std::printf("long_run: shape fit (%s%s), %d steps, %dx%d, %d views, start subdivisions %d, %d threads\n",
              options.appearance == fit::Appearance::Texture ? "texture" : "vertex colours",
              options.fit_camera ? ", cameras" : "", options.iterations, options.size, options.size, options.views,
              options.start_subdivisions, options.threads > 0 ? options.threads : gr::num_threads());
  std::ostringstream log;
  bool threw = false;
  fit::FitResult result;
  try {
    result = fit::run_fit(options, log);
  } catch (const std::exception& e) {
    std::printf("run_fit threw: %s\n", e.what());
    threw = true;
  }
  std::error_code ignored;
  std::filesystem::remove_all(out, ignored);

  const bool params_finite = !threw && all_finite(result.positions) && all_finite(result.colours) &&
                             all_finite(result.texture);
  bool finite = losses_finite && params_finite;
  if (!threw)
    for (double l : result.losses) finite = finite && std::isfinite(l);
  std::printf("losses finite: %s, fitted parameters finite: %s\n", losses_finite && !threw ? "yes" : "NO",
              params_finite ? "yes" : "NO");
  if (!threw)
    std::printf("loss %.6f -> %.6f, IoU %.3f -> %.3f, %.1f steps/s\n", result.initial_loss, result.final_loss,
                result.initial_iou, result.final_iou, result.iterations_per_second);

  bool flat = true;
  const Checkpoint* from = nullptr;
  for (const Checkpoint& c : checkpoints)
    if (c.step == 100) from = &c;
  if (from && checkpoints.back().step > from->step) {
    const Checkpoint& to = checkpoints.back();
    const long grown = to.memory.rss_kib - from->memory.rss_kib;
    flat = !(grown > 8 * 1024 && grown > from->memory.rss_kib / 10);
    std::printf("RSS step %d -> %d: %+.1f MiB (%s); fresh allocations %+lld\n", from->step, to.step,
                grown / 1024.0, flat ? "flat" : "GROWING",
                static_cast<long long>(to.fresh_allocations - from->fresh_allocations));
  }
  return finite && flat && !threw ? 0 : 1;
}
