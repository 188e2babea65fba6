// Shading models written with the tensor API: Lambert, Blinn-Phong, tangent-
// space normal mapping and a spherical-harmonics environment light. Each is a
// few lines of ordinary ops (dot, normalize, cross, slice, matmul, ...), so
// every one is differentiable end to end with no hand-written adjoint: copy
// one into your program and a loss on the image reaches the albedo, the
// normals, the light, the normal map or the SH coefficients.
//
// Conventions shared by all functions:
// - Vectors live on the last axis: normals, directions and positions are
//   [..., 3], colours [..., 3]; every argument broadcasts against the others
//   (a light [3] lights an [H, W, 3] image).
// - `normal` is unit length (normalize an interpolated normal first) and all
//   vectors are in one space (world space in examples/shading/main.cpp).
// - Arguments of one call share one float dtype (float32 or float64).
// - Results are linear radiance; apply a display transform (gamma) yourself.
#pragma once

#include "autodiff/tensor.h"

namespace gr::shading {

// Lambert (ideal diffuse): albedo * max(n . l, 0).
// albedo [..., 3], normal [..., 3] unit, light_dir [..., 3] unit, pointing
// TOWARDS the light -> [..., 3].
Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light_dir);

// Blinn-Phong with a point light of unit intensity:
//   l = normalize(light_pos - p), v = normalize(eye_pos - p), h = normalize(l + v),
//   colour = albedo * max(n . l, 0) + specular * max(n . h, 0)^shininess * [n . l > 0].
// The step [n . l > 0] (a mask, no gradient) keeps a light behind the
// surface from leaving a highlight, as OpenGL's fixed-function lighting does.
// albedo, specular [..., 3]; normal, position [..., 3]; light_pos, eye_pos [3]
// (or per pixel); shininess broadcastable to [..., 1] (e.g. a scalar tensor).
// Differentiable w.r.t. all of them (shininess included, so it can be fitted).
Tensor blinn_phong(const Tensor& albedo, const Tensor& normal, const Tensor& position, const Tensor& light_pos,
                   const Tensor& eye_pos, const Tensor& shininess, const Tensor& specular);

// Tangent-space normal mapping. `tangent_space_normal` is the normal-map
// texel in [0, 1]^3 (OpenGL convention: green = +bitangent = direction of
// increasing v), decoded as m = 2 texel - 1. With N = normal (unit),
//   T = normalize(tangent - N (N . tangent))   (Gram-Schmidt against N)
//   B = N x T
//   n' = normalize(T m.x + B m.y + N m.z).
// The texel (0.5, 0.5, 1) (m = (0, 0, 1)) returns N. B = N x T assumes a
// right-handed uv mapping (no mirrored uvs; those need a per-vertex sign).
// normal, tangent, tangent_space_normal: [..., 3] -> [..., 3].
Tensor perturb_normal(const Tensor& normal, const Tensor& tangent, const Tensor& tangent_space_normal);

// Per-vertex tangents (direction of increasing u on the surface) of a mesh:
// positions [N, 3], uvs [N, 2], triangles [M, 3] int32 -> [N, 3] unit vectors.
// Per triangle, with e1 = p1 - p0, e2 = p2 - p0, (du1, dv1) = uv1 - uv0,
// (du2, dv2) = uv2 - uv0 and det = du1 dv2 - du2 dv1, dp/du = (dv2 e1 - dv1 e2)
// / det. Each face adds sign(det) (dv2 e1 - dv1 e2) = |det| dp/du to its three
// corners (scatter_add), i.e. dp/du weighted by twice the face's uv area, so a
// face with degenerate uvs adds (almost) nothing instead of dividing by zero;
// the sums are normalized. A vertex whose faces all have degenerate uvs gets
// a zero tangent, which perturb_normal turns into "no perturbation".
// Differentiable w.r.t. positions and uvs (sign(det) is piecewise constant).
Tensor vertex_tangents(const Tensor& positions, const Tensor& uvs, const Tensor& triangles);

// The spherical-harmonics constants of Ramamoorthi & Hanrahan 2001, "An
// Efficient Representation for Irradiance Environment Maps".
// Coefficient order (l, m): (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0),
// (2,1), (2,2); basis at a unit direction (x, y, z):
//   Y00 = 0.282095
//   Y1-1 = 0.488603 y,  Y10 = 0.488603 z,  Y11 = 0.488603 x
//   Y2-2 = 1.092548 xy, Y2-1 = 1.092548 yz, Y21 = 1.092548 xz
//   Y20 = 0.315392 (3z^2 - 1),  Y22 = 0.546274 (x^2 - y^2)
// and the clamped-cosine convolution constants A0 = pi, A1 = 2pi/3, A2 = pi/4.
// (The paper's axes are used as given: no axis is special for the irradiance,
// so a y-up world needs no swap.)
constexpr int kShCoefficients = 9;

// The 9 basis values Y_lm(d) per direction: d [..., 3] unit -> [..., 9].
Tensor sh_basis(const Tensor& direction);

// Irradiance of an environment with SH radiance coefficients `sh` [9, 3]
// (one column per colour channel; L_lm = integral of L(w) Y_lm(w) dw):
//   E(n) = sum_lm A_l L_lm Y_lm(n),
// evaluated as matmul(sh_basis(n) [P, 9], A * sh [9, 3]).
// normal [..., 3] unit -> [..., 3]. Differentiable w.r.t. sh and normal.
Tensor sh_irradiance(const Tensor& normal, const Tensor& sh);

// Diffuse shading under the SH environment: albedo * E(n) / pi (the Lambert
// BRDF albedo / pi times the irradiance). albedo [..., 3] -> [..., 3].
Tensor sh_diffuse(const Tensor& albedo, const Tensor& normal, const Tensor& sh);

// SH coefficients [9, 3] of a distant directional light: radiance
// colour * delta(w - direction), so L_lm = colour Y_lm(direction). Its order-2
// irradiance approximates colour * max(n . direction, 0) (the clamped cosine).
// direction [3] unit (towards the light), colour [3].
Tensor sh_directional_light(const Tensor& direction, const Tensor& colour);

// SH coefficients [9, 3] of a sky of radiance `sky` over the hemisphere
// around `up` and a ground of radiance `ground` below it:
//   L00 = 2pi Y00 (sky + ground), L1m = pi (sky - ground) Y1m(up), l = 2 zero.
// Its irradiance is exact: E(n) = pi/2 ((sky + ground) + (sky - ground) n . up).
// up [3] unit, sky and ground [3].
Tensor sh_sky_ground(const Tensor& up, const Tensor& sky, const Tensor& ground);

}  // namespace gr::shading
