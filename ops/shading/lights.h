// Lights: where the light comes from and how much arrives. A light sample
// gives the unit direction towards the light and the incoming radiance, so
// shading with it reads
//   cook_torrance(base_color, metallic, roughness, n, light.direction, v) * light.radiance.
// environment_light looks radiance up in a cube map; reflect_view gives the
// mirror direction to look up. Conventions as in brdf.h; every float
// argument gets a gradient.
#pragma once

#include "autodiff/base/tensor.h"
#include "ops/render/cube_texture.h"  // CubeTextureOptions

namespace gr::shading {

struct LightSample {
  Tensor direction;  // [..., 3] unit, from the surface towards the light
  Tensor radiance;   // [..., C] incoming radiance
};

// A distant light: direction [..., 3] (towards the light, any length),
// radiance [..., C] (any float tensor of direction's dtype) ->
// {normalize(direction), radiance} (radiance is passed on as is).
LightSample directional_light(const Tensor& direction, const Tensor& radiance);

// A point light at light_position [..., 3] with intensity [..., C], seen from
// surface points `position` [..., 3] (the two broadcast; intensity broadcasts
// against their [..., 1]): with d = light_position - position,
//   {normalize(d), intensity / max(|d|^2, 1e-12)}   (inverse-square falloff).
LightSample point_light(const Tensor& light_position, const Tensor& intensity, const Tensor& position);

// Radiance from a distant environment stored as a cube map [6, S, S, C]
// (ops/render/cube_texture.h: +X, -X, +Y, -Y, +Z, -Z), looked up along
// direction [..., 3] (any length) -> [..., C]. Bilinear without mipmaps by
// default; options, dir_da and mip_level_bias are cube_texture's.
// Differentiable w.r.t. the cube map and the direction (and, trilinear, the
// derivatives and bias).
Tensor environment_light(const Tensor& cube_map, const Tensor& direction, const CubeTextureOptions& options = {},
                         const Tensor& dir_da = {}, const Tensor& mip_level_bias = {});

// The view direction mirrored about the normal: 2 (n.v) n - v, for
// environment lookups of a mirror-like surface. view_dir, normal [..., 3] -> [..., 3].
Tensor reflect_view(const Tensor& view_dir, const Tensor& normal);

}  // namespace gr::shading
