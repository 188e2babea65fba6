// The hand-fused textured baseline (bench/fused_textured.h) computes the same
// loss and gradients as the tape does for textured_graph.h's graph, and its
// results do not depend on the thread count.
#include <catch2/catch.hpp>

#include "fused_textured.h"
#include "test_support.h"

using namespace gr;

using gr::testing::max_relative_difference;

TEST_CASE("fused textured baseline: the hand-fused passes give the tape's loss and gradients in float64",
          "[bench][fused]") {
  // 160 x 120 pixels on a 48 x 48 texture: several summation blocks, pixels
  // sharing texels, and the texel rows split into bands.
  auto scene = bench::make_textured_scene(160, 120, 48, DType::Float64);
  Tensor loss = bench::textured_loss(scene);
  const double tape_loss = loss.item();
  backward(loss);
  bench::FusedTexturedGradients<double> fused;
  bench::fused_textured(scene, fused);
  CHECK(fused.loss == Approx(tape_loss).epsilon(1e-12));
  CHECK(max_relative_difference(fused.tex, scene.tex.grad().to_vector()) < 1e-12);
  CHECK(max_relative_difference(fused.uv, scene.uv.grad().to_vector()) < 1e-12);
}

TEST_CASE("fused textured baseline: loss and gradients are bit-identical for 1 2 and 8 threads",
          "[bench][fused][determinism]") {
  auto scene = bench::make_textured_scene(300, 200, 64, DType::Float32);
  bench::FusedTexturedGradients<float> reference;
  set_num_threads(1);
  bench::fused_textured(scene, reference);
  for (int threads : {2, 8}) {
    set_num_threads(threads);
    bench::FusedTexturedGradients<float> other;
    bench::fused_textured(scene, other);
    CHECK(other.loss == reference.loss);
    CHECK(other.tex == reference.tex);
    CHECK(other.uv == reference.uv);
  }
  set_num_threads(0);
}
