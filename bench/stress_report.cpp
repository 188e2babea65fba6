// stress_report: runs every numerical-stability stress scene of
// tests/stress/stress_scenes.h (issue 7) and prints one table row per case:
// finiteness of image and gradients in float64 and float32, the float64
// gradcheck's worst relative error (over the inputs the case marks smooth),
// and the float32-vs-float64 relative error of the image and of the gradients
// (max |a32 - a64| / max |a64|, worst input). Exit code 1 if any output or
// gradient is NaN/Inf or a gradcheck fails.
//
//   build/bench/stress_report            # the table
//   build/bench/stress_report --threads 1
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "examples/common/cli_args.h"
#include "stress/stress_scenes.h"

int main(int argc, char** argv) {
  using namespace gr;
  const char* usage =
      "Usage: stress_report [--threads N]\n"
      "Runs every numerical stress scene (tests/stress) and prints a table (docs/robustness.md).\n"
      "  --threads N   worker threads, 0 = all (default 0)\n"
      "Exit codes: 0 all finite and every gradcheck passed, 1 otherwise, 2 usage error.\n";
  cli::parse_flags_or_exit("stress_report", usage, argc, argv, {{"--threads"}, {}},
                           [](const std::string& flag, const std::string& value) {
                             set_num_threads(cli::parse_int(flag, value, 0, 1024));
                           });
  const auto t0 = std::chrono::steady_clock::now();
  bool ok = true;
  std::printf("| %-12s | %-38s | f64 finite | f32 finite | gradcheck rel err (f64)    | f32 vs f64 image | f32 vs f64 grad      | cov. diff |\n",
              "group", "case");
  std::printf("|--------------|----------------------------------------|------------|------------|----------------------------|------------------|----------------------|-----------|\n");
  for (const stress::Case& c : stress::all_cases()) {
    const stress::Evaluation e64 = stress::evaluate(c, DType::Float64);
    const stress::Evaluation e32 = stress::evaluate(c, DType::Float32);
    const stress::Comparison cmp = stress::compare(c, e32, e64);
    std::string gc = "-";
    if (!c.checks.empty()) {
      double worst = 0;
      bool passed = true;
      std::string which;
      for (const auto& check : c.checks) {
        const stress::GradcheckRun run = stress::run_gradcheck(c, check);
        worst = std::max(worst, run.result.max_rel_error);
        passed = passed && run.result.passed && run.coverage_changes == 0;
        for (int k : check.inputs) which += (which.empty() ? "" : ",") + c.input_names[k].substr(0, 3);
      }
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.1e %s (%s)", worst, passed ? "ok" : "FAIL", which.c_str());
      gc = buf;
      ok = ok && passed;
    }
    ok = ok && e64.finite() && e32.finite();
    char grad[64];
    std::snprintf(grad, sizeof grad, "%.1e (%s)", cmp.grad_rel, cmp.worst_grad.c_str());
    std::printf("| %-12s | %-38s | %-10s | %-10s | %-26s | %-16.1e | %-20s | %9lld |\n", c.group.c_str(),
                c.name.c_str(), e64.finite() ? "yes" : "NO", e32.finite() ? "yes" : "NO", gc.c_str(), cmp.image_rel,
                grad, static_cast<long long>(cmp.coverage_diff));
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("\nrel err = max|a32 - a64| / max|a64| per tensor (gradients: worst input). gradcheck: float64, "
              "4th-order central differences over the inputs in parentheses (pos = positions, col = colours, ver = the "
              "near-plane vertex), worst relative error with gradcheck's scale floor; ok = every element within "
              "atol + rtol |numeric| and no step changed the coverage; cov. diff = pixels whose tri_id differs "
              "between float32 and float64. %.1f s\n",
              s);
  return ok ? 0 : 1;
}
