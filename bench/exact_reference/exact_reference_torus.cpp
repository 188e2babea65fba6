// The exact reference on the time_error torus (128 x 128, 2304 triangles):
// its wall time and its agreement with the 16 x 16 supersampled render
// (no antialias), per pixel and channel.
//   build/bench/exact_reference_torus [threads]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "autodiff/parallel.h"
#include "autodiff/tape.h"
#include "bench/exact_reference/exact_reference.h"
#include "bench/time_error_scene.h"

int main(int argc, char** argv) {
  using namespace gr;
  if (argc > 1) set_num_threads(std::atoi(argv[1]));
  const bench::TimeErrorScene scene;
  NoGradGuard no_grad;
  const Tensor clip = scene.clip_positions(scene.points());
  const auto start = std::chrono::steady_clock::now();
  const bench::ExactImage exact = bench::exact_box_filtered(clip, scene.triangles(), scene.vertex_colours(scene.colours()),
                                                            scene.width(), scene.height(), scene.background());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("exact reference, torus %dx%d, %lld triangles, %d threads: %.3f s\n", scene.width(), scene.height(),
              static_cast<long long>(scene.triangles().size(0)), num_threads(), seconds);

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
  return 0;
}
