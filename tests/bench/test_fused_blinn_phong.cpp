// The hand-fused Blinn-Phong baseline (bench/fused_blinn_phong.h) computes the
// same loss and gradients as the tape does for shading_graph.h's graph, and
// its sums do not depend on the thread count.
#include <catch2/catch.hpp>

#include "fused_blinn_phong.h"
#include "test_support.h"

using namespace gr;

using gr::testing::max_relative_difference;

TEST_CASE("fused baseline: the hand-fused pass gives the tape's loss and gradients in float64",
          "[bench][fused]") {
  // 40000 pixels: several summation blocks, and some pixels with n.l or n.h <= 0.
  auto scene = bench::make_shading_scene(40000, DType::Float64);
  Tensor loss = bench::blinn_phong_loss(scene);
  const double tape_loss = loss.item();
  backward(loss);
  bench::FusedGradients<double> fused;
  bench::fused_blinn_phong(scene, fused);
  CHECK(fused.loss == Approx(tape_loss).epsilon(1e-12));
  CHECK(max_relative_difference(fused.n, scene.n.grad().to_vector()) < 1e-12);
  CHECK(max_relative_difference(fused.albedo, scene.albedo.grad().to_vector()) < 1e-12);
  const std::vector<double> light(fused.light.begin(), fused.light.end());
  CHECK(max_relative_difference(light, scene.light.grad().to_vector()) < 1e-12);
}

TEST_CASE("fused baseline: loss and light gradient are bit-identical for 1 2 and 8 threads",
          "[bench][fused][determinism]") {
  auto scene = bench::make_shading_scene(70000, DType::Float32);
  bench::FusedGradients<float> reference;
  set_num_threads(1);
  bench::fused_blinn_phong(scene, reference);
  for (int threads : {2, 8}) {
    set_num_threads(threads);
    bench::FusedGradients<float> other;
    bench::fused_blinn_phong(scene, other);
    CHECK(other.loss == reference.loss);
    CHECK(other.light == reference.light);
    CHECK(other.n == reference.n);
  }
  set_num_threads(0);
}

TEST_CASE("fused baseline: at the tape's precision the float32 pass is closer to the tape's float32 gradients",
          "[bench][fused]") {
  auto scene = bench::make_shading_scene(40000, DType::Float32);
  backward(bench::blinn_phong_loss(scene));
  const std::vector<double> tape_n = scene.n.grad().to_vector();
  bench::FusedGradients<float> fast, matched;
  bench::fused_blinn_phong<float, float>(scene, fast);
  bench::fused_blinn_phong<float, double>(scene, matched);
  auto as_double = [](const std::vector<float>& v) { return std::vector<double>(v.begin(), v.end()); };
  const double fast_error = max_relative_difference(as_double(fast.n), tape_n);
  const double matched_error = max_relative_difference(as_double(matched.n), tape_n);
  INFO("float accumulation " << fast_error << ", double accumulation " << matched_error);
  CHECK(matched_error < fast_error);
  CHECK(matched_error < 1e-6);
}
