// Order-2 spherical harmonics (formulas and constants in spherical_harmonics.h).
#include "ops/shading/spherical_harmonics.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "ops/check.h"
#include "ops/tensor/elementwise.h"
#include "ops/tensor/factories.h"
#include "ops/tensor/linalg.h"
#include "ops/shading/arguments.h"
#include "ops/tensor/shape_ops.h"
#include "ops/tensor/vector.h"

namespace gr::shading {
namespace {

using detail::kPi;

// Component k of [..., 3] vectors as [..., 1].
Tensor component(const Tensor& v, int k) { return slice(v, -1, k, k + 1); }

// ShapeError unless sh is [9, C] with C >= 1.
void check_coefficients(const Tensor& sh, const char* op) {
  gr::detail::check_float(sh, op, "sh");
  if (sh.rank() != 2 || sh.size(0) != kShCoefficients || sh.size(1) < 1)
    throw ShapeError(std::string(op) + ": argument 'sh' must have shape [9, C], got " + sh.describe());
}

// sh_basis without the argument checks.
Tensor basis(const Tensor& d) {
  const double c0 = std::sqrt(1 / (4 * kPi)), c1 = std::sqrt(3 / (4 * kPi)), c2 = std::sqrt(15 / (4 * kPi));
  const double c20 = std::sqrt(5 / (16 * kPi)), c22 = std::sqrt(15 / (16 * kPi));
  const Tensor x = component(d, 0), y = component(d, 1), z = component(d, 2);
  return concat({full_like(x, c0),                                         // l = 0
                 c1 * y, c1 * z, c1 * x,                                   // l = 1
                 c2 * x * y, c2 * y * z, c20 * (3.0 * z * z - 1.0), c2 * x * z,  // l = 2
                 c22 * (x * x - y * y)},
                -1);
}

// sh_irradiance with its checks under the name `op`.
Tensor irradiance(const Tensor& normal, const Tensor& sh, const char* op) {
  detail::check_vectors(normal, 3, op, "normal");
  check_coefficients(sh, op);
  gr::detail::check_same_dtype(sh, normal, op, "sh", "normal");
  // A_l per row: pi for l = 0, 2pi/3 for l = 1, pi/4 for l = 2.
  const double a1 = 2 * kPi / 3, a2 = kPi / 4;
  const Tensor a = Tensor::from_values({kPi, a1, a1, a1, a2, a2, a2, a2, a2}, {kShCoefficients, 1}, sh.dtype());
  // Flatten the leading axes to rows, [P, 9] x [9, C], and restore them.
  std::vector<std::int64_t> out_shape = normal.shape().dims();
  out_shape.back() = sh.size(1);
  return reshape(matmul(reshape(basis(normal), {-1, kShCoefficients}), a * sh), out_shape);
}

}  // namespace

Tensor sh_basis(const Tensor& direction) {
  detail::check_vectors(direction, 3, "shading::sh_basis", "direction");
  return basis(direction);
}

Tensor sh_irradiance(const Tensor& normal, const Tensor& sh) {
  return irradiance(normal, sh, "shading::sh_irradiance");
}

Tensor sh_diffuse(const Tensor& albedo, const Tensor& normal, const Tensor& sh) {
  constexpr const char* op = "shading::sh_diffuse";
  gr::detail::check_float(albedo, op, "albedo");
  const Tensor e = irradiance(normal, sh, op);
  gr::detail::check_same_dtype(albedo, normal, op, "albedo", "normal");
  detail::check_together(op, {{"irradiance(normal, sh)", e}, {"albedo", albedo}});
  return albedo * e / kPi;
}

Tensor sh_directional_light(const Tensor& direction, const Tensor& radiance) {
  constexpr const char* op = "shading::sh_directional_light";
  gr::detail::check_shape(direction, {3}, op, "direction");
  gr::detail::check_float(direction, op, "direction");
  gr::detail::check_float(radiance, op, "radiance");
  if (radiance.rank() != 1 || radiance.size(0) < 1)
    throw ShapeError(std::string(op) + ": argument 'radiance' must have shape [C], got " + radiance.describe());
  gr::detail::check_same_dtype(radiance, direction, op, "radiance", "direction");
  return reshape(basis(normalize(direction)), {kShCoefficients, 1}) * reshape(radiance, {1, -1});
}

}  // namespace gr::shading
