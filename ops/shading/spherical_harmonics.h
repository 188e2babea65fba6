// Environment lighting with spherical harmonics up to order 2 (Ramamoorthi &
// Hanrahan 2001, "An Efficient Representation for Irradiance Environment
// Maps", eqs. 3 and 12). Coefficient order (l, m): (0,0), (1,-1), (1,0),
// (1,1), (2,-2), (2,-1), (2,0), (2,1), (2,2); basis at a unit direction (x, y, z):
//   Y00  = sqrt(1/(4pi))                            (0.282095)
//   Y1-1 = sqrt(3/(4pi)) y,  Y10 = sqrt(3/(4pi)) z,  Y11 = sqrt(3/(4pi)) x      (0.488603)
//   Y2-2 = sqrt(15/(4pi)) xy, Y2-1 = sqrt(15/(4pi)) yz, Y21 = sqrt(15/(4pi)) xz (1.092548)
//   Y20  = sqrt(5/(16pi)) (3z^2 - 1)                (0.315392)
//   Y22  = sqrt(15/(16pi)) (x^2 - y^2)              (0.546274)
// and the clamped-cosine convolution constants A0 = pi, A1 = 2pi/3, A2 = pi/4.
// Coefficients `sh` are [9, C], one column per colour channel, L_lm = the
// integral of L(w) Y_lm(w) dw. No axis is special for irradiance, so a y-up
// world needs no swap. Everything is differentiable w.r.t. every float input.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr::shading {

constexpr int kShCoefficients = 9;

// The 9 basis values Y_lm(d) per direction: direction [..., 3] unit -> [..., 9].
Tensor sh_basis(const Tensor& direction);

// Irradiance E(n) = sum_lm A_l L_lm Y_lm(n) (eq. 12 without its expansion),
// evaluated as sh_basis(n) [P, 9] x (A sh) [9, C].
// normal [..., 3] unit, sh [9, C] -> [..., C].
Tensor sh_irradiance(const Tensor& normal, const Tensor& sh);

// Lambert shading under the environment: albedo * sh_irradiance(normal, sh) / pi.
// albedo [..., C] (broadcasting), normal [..., 3], sh [9, C] -> [..., C].
Tensor sh_diffuse(const Tensor& albedo, const Tensor& normal, const Tensor& sh);

// Coefficients [9, C] of a distant directional light of radiance
// radiance * delta(w - d), d = normalize(direction): L_lm = radiance Y_lm(d).
// Its order-2 irradiance approximates radiance * max(n.d, 0).
// direction [3] (towards the light), radiance [C].
Tensor sh_directional_light(const Tensor& direction, const Tensor& radiance);

}  // namespace gr::shading
