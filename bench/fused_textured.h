// The textured loss of textured_graph.h and its gradients written by hand:
// the texture-heavy fused baseline of issue 17. Pass 1 (parallel over pixels)
// runs the lookup, the loss and the uv adjoint per pixel with every value in
// registers; pass 2 scatters the texel gradients, one band of texel rows per
// task, each walking the pixels in order (so every texel sums in pixel order:
// the result does not depend on the thread count).
#pragma once

#include <vector>

#include "textured_graph.h"

namespace gr::bench {

template <class T>
struct FusedTexturedGradients {
  std::vector<T> tex, uv;  // as the scene's tensors
  T loss = 0;
  std::vector<T> g;        // scratch: dL/d(looked-up colour), kept between calls
};

template <class T>
void fused_textured(const TexturedScene& scene, FusedTexturedGradients<T>& out);

}  // namespace gr::bench
