// Tangent frames and tangent-space normal mapping. vertex_tangents builds a
// per-vertex tangent with a handedness sign from a mesh's uvs (MikkTSpace
// style: accumulate per-face uv derivatives, orthogonalize against the
// normal); perturb_normal turns a normal-map texel into a shading normal.
// Differentiable w.r.t. every float input (signs and handedness carry no gradient).
#pragma once

#include "autodiff/base/tensor.h"

namespace gr::shading {

// Per-vertex tangents with handedness: positions [V, 3], uvs [V, 2],
// triangles [M, 3] int32, normals [V, 3] unit -> [V, 4] = (t, w).
// Per face, e1 = p1 - p0, e2 = p2 - p0, (du1, dv1) = uv1 - uv0,
// (du2, dv2) = uv2 - uv0, det = du1 dv2 - du2 dv1, s = sign(det) (0 for det = 0):
//   t_face = s (dv2 e1 - dv1 e2)  (= |det| dp/du),  b_face = s (du1 e2 - du2 e1)  (= |det| dp/dv),
// i.e. the uv derivatives weighted by twice the face's uv area, so a face with
// degenerate uvs adds nothing. t_acc, b_acc sum them at each vertex (faces in
// ascending order: bit-identical for any thread count). Then (Gram-Schmidt)
//   t = normalize(t_acc - n (n . t_acc)),
//   w = dot(cross(n, t), b_acc) < 0 ? -1 : +1   (-1 where the uvs are mirrored).
// A vertex with only degenerate-uv faces gets t = 0 and w = +1 (perturb_normal
// then leaves its normal unchanged).
Tensor vertex_tangents(const Tensor& positions, const Tensor& uvs, const Tensor& triangles, const Tensor& normals);

// Tangent-space normal mapping (OpenGL convention: green = +v):
//   m = 2 texel - 1,
//   t = normalize(tangent.xyz - n (n . tangent.xyz)),  b = tangent.w cross(n, t),
//   n' = normalize(t m.x + b m.y + n m.z).
// The texel (0.5, 0.5, 1) returns n; a zero tangent gives n' = normalize(n m.z).
// normal [..., 3] unit, tangent [..., 4] (vertex_tangents' (t, w), e.g.
// interpolated), texel [..., 3] in [0, 1] -> [..., 3].
Tensor perturb_normal(const Tensor& normal, const Tensor& tangent, const Tensor& texel);

}  // namespace gr::shading
