// Light samples, environment lookups and the reflected view direction
// (formulas in lights.h).
#include "ops/shading/lights.h"

#include <string>

#include "autodiff/base/error.h"
#include "ops/check.h"
#include "ops/tensor/elementwise.h"
#include "ops/shading/arguments.h"
#include "ops/tensor/vector.h"

namespace gr::shading {

LightSample directional_light(const Tensor& direction, const Tensor& radiance) {
  constexpr const char* op = "shading::directional_light";
  detail::check_vectors(direction, 3, op, "direction");
  gr::detail::check_float(radiance, op, "radiance");
  gr::detail::check_same_dtype(radiance, direction, op, "radiance", "direction");
  return {normalize(direction), radiance};
}

LightSample point_light(const Tensor& light_position, const Tensor& intensity, const Tensor& position) {
  constexpr const char* op = "shading::point_light";
  detail::check_vectors(light_position, 3, op, "light_position");
  gr::detail::check_float(intensity, op, "intensity");
  detail::check_vectors(position, 3, op, "position");
  detail::check_together(op, {{"light_position", light_position}, {"position", position}});
  gr::detail::check_same_dtype(intensity, light_position, op, "intensity", "light_position");
  const Tensor d = light_position - position;
  const Tensor squared_distance = maximum(dot(d, d), 1e-12);  // [..., 1]
  detail::check_together(op, {{"|light_position - position|^2", squared_distance}, {"intensity", intensity}});
  return {normalize(d), intensity / squared_distance};
}

Tensor environment_light(const Tensor& cube_map, const Tensor& direction, const CubeTextureOptions& options,
                         const Tensor& dir_da, const Tensor& mip_level_bias) {
  constexpr const char* op = "shading::environment_light";
  gr::detail::check_float(cube_map, op, "cube_map");
  if (cube_map.rank() != 4 || cube_map.size(0) != 6 || cube_map.size(1) != cube_map.size(2) ||
      cube_map.size(1) < 1 || cube_map.size(3) < 1)
    throw ShapeError(std::string(op) + ": argument 'cube_map' must have shape [6, S, S, C] with S, C >= 1, got " +
                     cube_map.describe());
  detail::check_vectors(direction, 3, op, "direction");
  gr::detail::check_same_dtype(direction, cube_map, op, "direction", "cube_map");
  return cube_texture(cube_map, direction, options, dir_da, mip_level_bias);
}

Tensor reflect_view(const Tensor& view_dir, const Tensor& normal) {
  constexpr const char* op = "shading::reflect_view";
  detail::check_vectors(view_dir, 3, op, "view_dir");
  detail::check_vectors(normal, 3, op, "normal");
  detail::check_together(op, {{"view_dir", view_dir}, {"normal", normal}});
  return 2.0 * dot(normal, view_dir) * normal - view_dir;
}

}  // namespace gr::shading
