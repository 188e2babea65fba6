// Reflection models (BRDFs) as differentiable compositions of tensor ops.
// Each shading model returns BRDF x cosine: the radiance reflected towards
// the viewer for unit incoming radiance from the light direction (multiply by
// a light's radiance, ops/shading/lights.h).
//
// Conventions: vectors on the last axis ([..., 3]); every argument broadcasts
// against the others (a light [3] lights an [H, W, 3] image); per-element
// scalars (shininess, metallic, roughness) are [..., 1] or rank 0. `normal`
// is unit length; `light_dir` and `view_dir` are unit and point AWAY from the
// surface (towards the light / the viewer). All float arguments of one call
// share one dtype (float32 or float64), and every one of them gets a gradient;
// masks such as [n.l > 0] carry none. At a kink of max(., c) the gradient is
// split evenly between the two sides (ops/tensor/elementwise.h).
#pragma once

#include "autodiff/base/tensor.h"

namespace gr::shading {

// Lambert (ideal diffuse): albedo * max(n.l, 0) / pi.
// albedo [..., 3], normal [..., 3], light_dir [..., 3] -> [..., 3].
Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light_dir);

// Blinn-Phong (Blinn 1977) with a Lambert diffuse term:
//   h = normalize(l + v),
//   albedo * max(n.l, 0) / pi + specular * max(n.h, 0)^shininess * [n.l > 0].
// The step [n.l > 0] (no gradient) keeps a light behind the surface from
// leaving a highlight. albedo, specular [..., 3]; shininess [..., 1]; normal,
// light_dir, view_dir [..., 3] -> [..., 3].
Tensor blinn_phong(const Tensor& albedo, const Tensor& specular, const Tensor& shininess, const Tensor& normal,
                   const Tensor& light_dir, const Tensor& view_dir);

// The GGX / Trowbridge-Reitz normal distribution (Walter et al. 2007, eq. 33):
//   D = alpha^2 / (pi (n_dot_h^2 (alpha^2 - 1) + 1)^2),
// elementwise over broadcast arguments (alpha > 0: at alpha = 0 and
// n_dot_h = 1 it is 0/0; cook_torrance keeps alpha >= 0.03^2).
Tensor ggx_distribution(const Tensor& n_dot_h, const Tensor& alpha);

// The height-correlated Smith visibility V = G2 / (4 n.l n.v) for GGX
// (Heitz 2014, eq. 99; as in Filament and glTF 2.0 appendix B):
//   V = 0.5 / (n_dot_l sqrt(n_dot_v^2 (1 - alpha^2) + alpha^2)
//              + n_dot_v sqrt(n_dot_l^2 (1 - alpha^2) + alpha^2)),
// elementwise over broadcast arguments (finite unless n_dot_v = n_dot_l = 0;
// cook_torrance keeps n_dot_v >= 1e-4).
Tensor smith_ggx_correlated(const Tensor& n_dot_v, const Tensor& n_dot_l, const Tensor& alpha);

// Schlick's Fresnel approximation (Schlick 1994):
//   F = f0 + (1 - f0) (1 - cos_theta)^5,
// elementwise over broadcast arguments (cos_theta [..., 1], f0 [..., 3] gives [..., 3]).
Tensor fresnel_schlick(const Tensor& cos_theta, const Tensor& f0);

// The glTF 2.0 metallic-roughness BRDF (specification, appendix B) times n.l:
//   roughness_c = clamp(roughness, 0.03, 1)  (gradient 0 outside),  alpha = roughness_c^2
//   h = normalize(l + v)
//   NL = max(n.l, 0),  NV = max(n.v, 1e-4),  NH = max(n.h, 0),  VH = max(v.h, 0)
//   f0 = 0.04 (1 - metallic) + base_color metallic
//   F = fresnel_schlick(VH, f0)
//   diffuse  = (1 - F) (1 - metallic) base_color / pi
//   specular = F ggx_distribution(NH, alpha) smith_ggx_correlated(NV, NL, alpha)
//   result = (diffuse + specular) NL.
// base_color [..., 3] (linear); metallic, roughness [..., 1]; normal,
// light_dir, view_dir [..., 3] -> [..., 3].
Tensor cook_torrance(const Tensor& base_color, const Tensor& metallic, const Tensor& roughness, const Tensor& normal,
                     const Tensor& light_dir, const Tensor& view_dir);

}  // namespace gr::shading
