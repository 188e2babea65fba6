// A sky-and-ground environment for the shading gallery, as order-2 spherical
// harmonics coefficients for the library's SH lighting (ops/shading/
// spherical_harmonics.h: gr::shading::sh_irradiance, sh_diffuse).
#pragma once

#include "autodiff/base/tensor.h"

namespace gr::shading_example {

// SH coefficients [9, C] of a sky of radiance `sky` over the hemisphere
// around `up` and a ground of radiance `ground` below it:
//   L00 = 2pi Y00 (sky + ground),  L1m = pi (sky - ground) Y1m(up),  l = 2 zero
// (the half-sphere step is odd, so it has no l = 2 part). Its order-2
// irradiance is exact: E(n) = pi/2 ((sky + ground) + (sky - ground) n . up).
// up [3] unit, sky and ground [C]. Differentiable w.r.t. all three.
Tensor sh_sky_ground(const Tensor& up, const Tensor& sky, const Tensor& ground);

}  // namespace gr::shading_example
