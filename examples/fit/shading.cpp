// Lambert shading of a rasterized, vertex-coloured mesh with tensor ops:
// transform -> rasterize -> interpolate colour and normal -> shade.
#include "examples/fit/shading.h"

#include "examples/fit/geometry.h"
#include "ops/ops.h"

namespace fit {

using namespace gr;

Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light, double ambient) {
  return albedo * (ambient + (1.0 - ambient) * maximum(dot(normal, light), 0.0));
}

Render render(const Tensor& positions, const Tensor& colours, const Tensor& triangles, const Camera& camera,
              int size) {
  const Tensor clip = transform_points(positions, camera.view_projection);  // [N, 4]
  const GBuffer gb = rasterize(clip, triangles, {size, size});
  const Tensor albedo = interpolate(colours, clip, gb, triangles);          // [H, W, 3]
  const Tensor normal = normalize(interpolate(vertex_normals(positions, triangles), clip, gb, triangles));
  const Tensor covered = greater(cast(gb.tri_id, DType::Float32), Tensor::scalar(0.0));  // no gradient
  const Tensor coverage = reshape(covered, {size, size, 1});
  return {lambert(albedo, normal, camera.light) * coverage, coverage};
}

}  // namespace fit
