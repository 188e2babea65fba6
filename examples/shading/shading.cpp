// Lambert, Blinn-Phong, normal mapping and SH environment lighting as short
// compositions of tensor ops; the tape differentiates them (shading.h states
// the formulas).
#include "examples/shading/shading.h"

#include <string>
#include <vector>

#include "ops/ops.h"

namespace gr::shading {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Component k of [..., 3] vectors as [..., 1].
Tensor component(const Tensor& v, int k) { return slice(v, -1, k, k + 1); }

// Column k of an int32 [M, 3] triangle list as an [M] index tensor.
Tensor corner(const Tensor& triangles, int k) {
  return reshape(slice(triangles, 1, k, k + 1), {triangles.size(0)});
}

void require_vectors(const Tensor& t, const char* fn, const char* arg) {
  if (!t.defined() || t.rank() < 1 || t.size(-1) != 3)
    throw ShapeError(std::string(fn) + ": argument '" + arg + "' must have shape [..., 3], got " +
                     (t.defined() ? t.describe() : "an undefined tensor"));
}

}  // namespace

Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light_dir) {
  return albedo * maximum(dot(normal, light_dir), 0.0);
}

Tensor blinn_phong(const Tensor& albedo, const Tensor& normal, const Tensor& position, const Tensor& light_pos,
                   const Tensor& eye_pos, const Tensor& shininess, const Tensor& specular) {
  const Tensor l = normalize(light_pos - position);
  const Tensor v = normalize(eye_pos - position);
  const Tensor h = normalize(l + v);
  const Tensor n_dot_l = dot(normal, l);                              // [..., 1]
  const Tensor lit = greater(n_dot_l, scalar_like(n_dot_l, 0.0));     // mask, no gradient
  const Tensor highlight = pow(maximum(dot(normal, h), 0.0), shininess);
  return albedo * maximum(n_dot_l, 0.0) + specular * highlight * lit;
}

Tensor perturb_normal(const Tensor& normal, const Tensor& tangent, const Tensor& tangent_space_normal) {
  require_vectors(tangent_space_normal, "perturb_normal", "tangent_space_normal");
  const Tensor m = tangent_space_normal * 2.0 - 1.0;                   // [0, 1] -> [-1, 1]
  const Tensor t = normalize(tangent - normal * dot(normal, tangent));  // Gram-Schmidt
  const Tensor b = cross(normal, t);
  return normalize(t * component(m, 0) + b * component(m, 1) + normal * component(m, 2));
}

Tensor vertex_tangents(const Tensor& positions, const Tensor& uvs, const Tensor& triangles) {
  const Tensor i0 = corner(triangles, 0), i1 = corner(triangles, 1), i2 = corner(triangles, 2);
  const Tensor p0 = gather(positions, i0), uv0 = gather(uvs, i0);
  const Tensor e1 = gather(positions, i1) - p0, e2 = gather(positions, i2) - p0;  // [M, 3]
  const Tensor d1 = gather(uvs, i1) - uv0, d2 = gather(uvs, i2) - uv0;            // [M, 2]
  const Tensor du1 = slice(d1, 1, 0, 1), dv1 = slice(d1, 1, 1, 2);
  const Tensor du2 = slice(d2, 1, 0, 1), dv2 = slice(d2, 1, 1, 2);
  const Tensor det = du1 * dv2 - du2 * dv1;                                       // [M, 1]
  const Tensor sign = 1.0 - 2.0 * less(det, scalar_like(det, 0.0));               // no gradient
  const Tensor face = (e1 * dv2 - e2 * dv1) * sign;                               // |det| dp/du
  const Tensor corners = concat({i0, i1, i2}, 0);                                 // [3M]
  return normalize(scatter_add(concat({face, face, face}, 0), corners, positions.size(0)));
}

Tensor sh_basis(const Tensor& direction) {
  require_vectors(direction, "sh_basis", "direction");
  const Tensor x = component(direction, 0), y = component(direction, 1), z = component(direction, 2);
  const Tensor y00 = Tensor::full(x.shape(), 0.282095, direction.dtype());
  return concat({y00, 0.488603 * y, 0.488603 * z, 0.488603 * x,                 // l = 0, 1
                 1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3.0 * z * z - 1.0),
                 1.092548 * x * z, 0.546274 * (x * x - y * y)},                   // l = 2
                -1);
}

Tensor sh_irradiance(const Tensor& normal, const Tensor& sh) {
  require_vectors(normal, "sh_irradiance", "normal");
  if (sh.rank() != 2 || sh.size(0) != kShCoefficients)
    throw ShapeError("sh_irradiance: argument 'sh' must have shape [9, C], got " + sh.describe());
  // A_l per row: pi for l = 0, 2pi/3 for l = 1, pi/4 for l = 2.
  const double a1 = 2 * kPi / 3, a2 = kPi / 4;
  const Tensor a = Tensor::from_values({kPi, a1, a1, a1, a2, a2, a2, a2, a2}, {kShCoefficients, 1}, sh.dtype());
  // Flatten the pixels to rows, [P, 9] x [9, C], and restore the leading axes.
  std::vector<std::int64_t> out_shape = normal.shape().dims();
  out_shape.back() = sh.size(1);
  return reshape(matmul(reshape(sh_basis(normal), {-1, kShCoefficients}), a * sh), out_shape);
}

Tensor sh_diffuse(const Tensor& albedo, const Tensor& normal, const Tensor& sh) {
  return albedo * sh_irradiance(normal, sh) * (1.0 / kPi);
}

Tensor sh_directional_light(const Tensor& direction, const Tensor& colour) {
  return reshape(sh_basis(direction), {kShCoefficients, 1}) * reshape(colour, {1, -1});
}

Tensor sh_sky_ground(const Tensor& up, const Tensor& sky, const Tensor& ground) {
  const Tensor l0 = reshape((2 * kPi * 0.282095) * (sky + ground), {1, -1});               // [1, C]
  const Tensor l1 = reshape(slice(sh_basis(up), 0, 1, 4), {3, 1}) * reshape(kPi * (sky - ground), {1, -1});
  const Tensor l2 = Tensor::zeros({5, l0.size(1)}, l0.dtype());                          // odd step: no l = 2
  return concat({l0, l1, l2}, 0);
}

}  // namespace gr::shading
