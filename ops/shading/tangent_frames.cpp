// Tangent frames and normal mapping (formulas in tangent_frames.h).
#include "ops/shading/tangent_frames.h"

#include "ops/check.h"
#include "ops/tensor/elementwise.h"
#include "ops/shading/arguments.h"
#include "ops/tensor/shape_ops.h"
#include "ops/tensor/vector.h"

namespace gr::shading {
namespace {

// Component k of [..., n] vectors as [..., 1].
Tensor component(const Tensor& v, int k) { return slice(v, -1, k, k + 1); }

// Corner k of every triangle, [M] int32.
Tensor corner(const Tensor& triangles, int k) { return reshape(slice(triangles, 1, k, k + 1), {triangles.size(0)}); }

// Sums each face's row [M, 3] into its three corners' rows [V, 3]; src rows
// are (face, corner) in row-major order, so each vertex adds its faces in
// ascending order.
Tensor sum_at_corners(const Tensor& per_face, const Tensor& triangles, std::int64_t vertices) {
  return scatter_add(stack({per_face, per_face, per_face}, 1), triangles, vertices);
}

// ShapeError unless t is [rows, cols] (names the vertex count "V").
void check_per_vertex(const Tensor& t, std::int64_t rows, std::int64_t cols, const char* op, const char* name) {
  gr::detail::check_float(t, op, name);
  gr::detail::check_shape(t, {rows, cols}, op, name);
}

}  // namespace

Tensor vertex_tangents(const Tensor& positions, const Tensor& uvs, const Tensor& triangles, const Tensor& normals) {
  constexpr const char* op = "shading::vertex_tangents";
  gr::detail::check_float(positions, op, "positions");
  gr::detail::check_columns(positions, 3, op, "positions", "V");
  const std::int64_t v = positions.size(0);
  check_per_vertex(uvs, v, 2, op, "uvs");
  check_per_vertex(normals, v, 3, op, "normals");
  gr::detail::check_same_dtype(uvs, positions, op, "uvs", "positions");
  gr::detail::check_same_dtype(normals, positions, op, "normals", "positions");
  gr::detail::check_triangles(triangles, v, op);

  const Tensor i0 = corner(triangles, 0), i1 = corner(triangles, 1), i2 = corner(triangles, 2);
  const Tensor p0 = gather(positions, i0), uv0 = gather(uvs, i0);
  const Tensor e1 = gather(positions, i1) - p0, e2 = gather(positions, i2) - p0;  // [M, 3]
  const Tensor d1 = gather(uvs, i1) - uv0, d2 = gather(uvs, i2) - uv0;            // [M, 2]
  const Tensor du1 = component(d1, 0), dv1 = component(d1, 1);
  const Tensor du2 = component(d2, 0), dv2 = component(d2, 1);
  const Tensor det = du1 * dv2 - du2 * dv1;                         // [M, 1]
  const Tensor sign = (det > 0.0) - (det < 0.0);                    // masks: no gradient
  const Tensor t_face = sign * (dv2 * e1 - dv1 * e2);               // |det| dp/du
  const Tensor b_face = sign * (du1 * e2 - du2 * e1);               // |det| dp/dv
  const Tensor t_acc = sum_at_corners(t_face, triangles, v);       // [V, 3]
  const Tensor b_acc = sum_at_corners(b_face, triangles, v);
  const Tensor t = normalize(t_acc - normals * dot(normals, t_acc));  // Gram-Schmidt against n
  const Tensor mirrored = dot(cross(normals, t), b_acc) < 0.0;         // mask: no gradient
  return concat({t, 1.0 - 2.0 * mirrored}, -1);
}

Tensor perturb_normal(const Tensor& normal, const Tensor& tangent, const Tensor& texel) {
  constexpr const char* op = "shading::perturb_normal";
  detail::check_vectors(normal, 3, op, "normal");
  detail::check_vectors(tangent, 4, op, "tangent");
  detail::check_vectors(texel, 3, op, "texel");
  const Tensor tangent_xyz = slice(tangent, -1, 0, 3), w = component(tangent, 3);
  detail::check_together(op, {{"normal", normal}, {"tangent", tangent_xyz}, {"texel", texel}});
  const Tensor m = 2.0 * texel - 1.0;                                          // [0, 1] -> [-1, 1]
  const Tensor t = normalize(tangent_xyz - normal * dot(normal, tangent_xyz));  // Gram-Schmidt against n
  const Tensor b = w * cross(normal, t);
  return normalize(t * component(m, 0) + b * component(m, 1) + normal * component(m, 2));
}

}  // namespace gr::shading
