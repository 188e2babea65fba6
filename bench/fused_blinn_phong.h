// The Blinn-Phong loss of shading_graph.h and its gradients written by hand as
// one pass over the pixels: the fused baseline that the tape's time is
// measured against (issue 17). Same formulas, same inputs (a ShadingScene), no
// intermediate tensors: pixels go in blocks of 64, copied into one small array
// per component so that the per-pixel forward and adjoint are one loop the
// compiler vectorizes (8 float32 lanes with AVX2); each lane's values stay in
// registers. (Session 8's version walked the pixels one at a time, unvectorized,
// and took 3.8x (1 thread) to 4.7x (2 threads) as long: docs/roofline.md.)
#pragma once

#include <array>
#include <vector>

#include "shading_graph.h"

namespace gr::bench {

template <class T>
struct FusedGradients {
  std::vector<T> n, albedo;  // [N * 3], as the scene's tensors
  std::array<T, 3> light{};
  T loss = 0;
};

// Loss and dL/dn, dL/dalbedo, dL/dlight of blinn_phong_loss(scene), with
// max(x, 0)'s derivative taken as 1 for x > 0 and 0 otherwise. The per-pixel
// work is split over threads; the loss and the light gradient are summed in
// fixed blocks (deterministic_sum), so results do not depend on the thread count.
// Acc: the precision of dot products, lengths and normalize's adjoint. T is
// the fastest pass; double gives float32 the tape's own precision (its dot
// and normalize accumulate in double), the like-for-like baseline.
template <class T, class Acc = T>
void fused_blinn_phong(const ShadingScene& scene, FusedGradients<T>& out);

}  // namespace gr::bench
