// The exact reference on the time_error torus (128 x 128, 2304 triangles):
// its wall time and its agreement with the 16 x 16 supersampled render
// (no antialias), per pixel and channel, and the change from quadrature
// order 8 (the default) to 16; then position derivatives of the loss
// mean((image - target)^2) by finite differences along time_error's random
// directions, of the exact image and of the 16 x 16 supersampled one, with
// each one's spread (second-order differences at steps h and 2h).
//   build/bench/exact_reference_torus [threads]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "bench/time_error_exact.h"
#include "ops/ops.h"
#include "bench/time_error_reference.h"
#include "bench/time_error_scene.h"
#include "examples/common/cli_args.h"

int main(int argc, char** argv) {
  using namespace gr;
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    std::printf("usage: exact_reference_torus [THREADS]   (worker threads, 0 = all; docs/exact_reference.md)\n");
    return 0;
  }
  try {
    if (args.size() > 1) throw cli::UsageError("unexpected argument " + cli::quoted(args[1]));
    if (!args.empty()) set_num_threads(cli::parse_int("THREADS", args[0], 0, 1024));
  } catch (const cli::UsageError& e) {
    std::fprintf(stderr, "exact_reference_torus: %s\n(run exact_reference_torus --help for usage)\n", e.what());
    return 2;
  }
  const bench::TimeErrorScene scene;
  NoGradGuard no_grad;
  const auto exact_image = [&](const Tensor& points, int order) {
    bench::ExactReferenceOptions options;
    options.quadrature_order = order;
    return bench::exact_scene_image(scene, points, scene.colours(), options);
  };
  const auto start = std::chrono::steady_clock::now();
  const bench::ExactImage exact = exact_image(scene.points(), 8);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("exact reference, torus %dx%d, %lld triangles, %d threads: %.3f s\n", scene.width(), scene.height(),
              static_cast<long long>(scene.triangles().size(0)), num_threads(), seconds);
  const std::vector<double> a8 = exact.image.to_vector(), a16 = exact_image(scene.points(), 16).image.to_vector();
  double order_diff = 0;
  for (std::size_t i = 0; i < a8.size(); ++i) order_diff = std::max(order_diff, std::abs(a8[i] - a16[i]));
  std::printf("quadrature order 8 vs 16: max |diff| %.3g\n", order_diff);

  for (int s : {4, 16}) {
    const Tensor ss = scene.render(scene.points(), scene.colours(), {DType::Float64, false, s});
    const double* a = exact.image.data<double>();
    const double* b = ss.data<double>();
    double max_diff = 0, sum_sq = 0, sum_sq_ref = 0;
    for (std::int64_t i = 0; i < ss.numel(); ++i) {
      max_diff = std::max(max_diff, std::abs(a[i] - b[i]));
      sum_sq += (a[i] - b[i]) * (a[i] - b[i]);
      sum_sq_ref += a[i] * a[i];
    }
    std::printf("vs %dx%d supersampling: max |diff| %.3g, RMS diff %.3g, relative L2 %.3g\n", s, s, max_diff,
                std::sqrt(sum_sq / ss.numel()), std::sqrt(sum_sq / sum_sq_ref));
  }
  double covered = 0;
  for (std::int64_t i = 0; i < exact.coverage.numel(); ++i) covered += exact.coverage.data<double>()[i];
  std::printf("covered area %.6f px^2\n", covered);

  // Finite differences as time_error takes them (bench/time_error_reference.h:
  // fourth-order stencil, spread = h vs 2h second-order differences), 8
  // fixed-seed smooth directions, at three steps, of the exact loss
  // (bench/time_error_exact.h) and of the 16 x 16 supersampled one.
  const bench::Directions directions = bench::random_directions(scene.points(), 8, 0, 20240613);
  const bench::SceneLoss exact_loss =
      bench::exact_scene_loss(scene, exact_image(scene.target_points(), 8).image);
  const bench::RenderSettings ss16{DType::Float64, false, 16};
  const bench::SceneLoss ss_loss =
      bench::rendered_loss(scene, scene.render(scene.target_points(), scene.colours(), ss16), ss16);
  std::printf("finite differences along %zu directions (relative L2; spread = h vs 2h second-order differences):\n",
              directions.position.size());
  std::vector<double> coarsest;
  for (double step_px : {0.25, 0.05, 0.01}) {
    const bench::ReferenceDerivatives ex = bench::finite_difference_reference(scene, exact_loss, directions, {step_px});
    const bench::ReferenceDerivatives ss = bench::finite_difference_reference(scene, ss_loss, directions, {step_px});
    if (coarsest.empty()) coarsest = ex.position;
    std::printf("  step %.2f px: exact spread %.3g (%.2f s), 16x16 spread %.3g (%.2f s), exact vs 16x16 %.3g, "
                "exact vs exact at 0.25 px %.3g\n",
                step_px, bench::relative_l2(ex.position_h, ex.position_2h), ex.seconds,
                bench::relative_l2(ss.position_h, ss.position_2h), ss.seconds,
                bench::relative_l2(ss.position, ex.position), bench::relative_l2(ex.position, coarsest));
  }
  return 0;
}
