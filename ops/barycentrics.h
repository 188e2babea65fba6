// Perspective-correct barycentrics and their screen-space derivatives per
// pixel (issue 11 item 3): nvdiffrast's rast (u, v) and rast_db, and the
// derivatives of any interpolated attribute, all differentiable w.r.t. the
// clip positions (for a fixed coverage) and the attributes.
//
// Our G-buffer's uv are screen-space barycentrics (interpolate applies 1/w
// itself). Here, per covered pixel centre p = (x + 0.5, y + 0.5, 1) (x right,
// y down, in pixels), with the triangle's homogeneous screen vertices
// V_k = (W/2 (x_k + w_k), H/2 (w_k - y_k), w_k) and c_k = V_k+1 x V_k+2:
//   F_k = p . c_k,  S = F_0 + F_1 + F_2,  b_k = F_k / S
// (homogeneous rasterization, Olano and Greer 1997: b_k = (lambda_k / w_k) /
// sum_j (lambda_j / w_j), the perspective-correct weights), and, since F_k is
// linear in p,
//   db_k/dx = (c_k.x S - F_k sum_j c_j.x) / S^2   (likewise y).
// These are composed from differentiable tensor ops on the covered pixels
// (fragments), so the tape derives their adjoints; the closed form above is
// what the tests check against (docs/rasterizer.md).
#pragma once

#include "autodiff/tensor.h"
#include "ops/rasterize.h"

namespace gr {

struct PerspectiveBarycentrics {
  Tensor uv;     // [H, W, 2]: (b1, b2); b0 = 1 - b1 - b2; 0 on background
  Tensor uv_db;  // [H, W, 4]: (db1/dx, db1/dy, db2/dx, db2/dy) per pixel; 0 on background
};

// clip [N, 4] float, triangles [M, 3] int32 and the G-buffer rasterize gave for
// them (its tri_id picks each pixel's triangle; its uv is not used).
PerspectiveBarycentrics perspective_barycentrics(const Tensor& clip, const Tensor& triangles, const GBuffer& gbuffer);

struct AttributeDerivatives {
  Tensor d_dx;  // [H, W, C]: d(attribute)/dx, x right, per pixel; 0 on background
  Tensor d_dy;  // [H, W, C]: d(attribute)/dy, y down (row order)
};

// Screen-space derivatives of the perspective-correct interpolation of
// attributes [N, C]: d/dx = sum_k (db_k/dx) a_k. Unlike
// interpolate_with_derivatives (whose derivatives are constants for the tape),
// these are differentiable w.r.t. the attributes and the clip positions, e.g.
// for a texture's level of detail (texture's uv_dx, uv_dy).
AttributeDerivatives attribute_derivatives(const Tensor& attributes, const Tensor& clip, const Tensor& triangles,
                                           const GBuffer& gbuffer);

}  // namespace gr
