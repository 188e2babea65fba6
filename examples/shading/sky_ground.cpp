// The sky/ground SH environment (formula in sky_ground.h), from the library's
// SH basis.
#include "examples/shading/sky_ground.h"

#include "ops/ops.h"

namespace gr::shading_example {

Tensor sh_sky_ground(const Tensor& up, const Tensor& sky, const Tensor& ground) {
  constexpr double kPi = 3.14159265358979323846;
  const Tensor y = reshape(shading::sh_basis(up), {shading::kShCoefficients, 1});  // [9, 1]
  const Tensor l0 = slice(y, 0, 0, 1) * reshape(2 * kPi * (sky + ground), {1, -1});  // [1, C]
  const Tensor l1 = slice(y, 0, 1, 4) * reshape(kPi * (sky - ground), {1, -1});      // [3, C]
  const Tensor l2 = Tensor::zeros({5, l0.size(1)}, l0.dtype());                      // [5, C]
  return concat({l0, l1, l2}, 0);
}

}  // namespace gr::shading_example
