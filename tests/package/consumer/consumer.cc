// Touches each layer of an installed gradraster: a tensor (base), a procedural
// mesh (raster) and a gradient through an op (tape + ops). Prints the gradient.
#include <cstdio>

#include "autodiff/tape.h"
#include "ops/ops.h"
#include "raster/procedural.h"

int main() {
  gr::Tensor x = gr::Tensor::from_vector<double>({1, 2, 3}, {3}).set_requires_grad();
  gr::backward(gr::sum(x * x));
  const gr::Tensor g = x.grad();
  const auto mesh = gr::raster::make_icosphere(1);
  std::printf("grad %g %g %g, icosphere %lld vertices\n", g.at({0}), g.at({1}), g.at({2}),
              static_cast<long long>(mesh.positions.numel() / 3));
  return 0;
}
