// Lambert shading of a rasterized mesh with tensor ops, composited over a
// background and antialiased so that silhouette pixels depend smoothly on the
// vertex positions.
#include "examples/fit/shading.h"

#include "autodiff/base/error.h"
#include "ops/ops.h"

namespace fit {

using namespace gr;

Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light, double ambient) {
  return albedo * (ambient + (1.0 - ambient) * maximum(dot(normal, light), 0.0));
}

Tensor shade_over_background_rows(const std::vector<Tensor>& rows, const std::vector<Tensor>& shared) {
  const Tensor& coverage = rows[2];
  return lambert(rows[0], normalize(rows[1]), shared[0]) * coverage + shared[1] * (1.0 - coverage);
}

Tensor shade_over_background(const Tensor& albedo, const Tensor& normal, const Tensor& coverage, const Tensor& light,
                             const Tensor& background) {
  return map_rows(shade_over_background_rows, {albedo, normal, coverage}, {light, background});
}

// Per pixel: |rgb - t|^2 / 3 + (alpha - t_alpha)^2, a dot with weights; its
// mean over pixels is the mean over the colour channels plus the alpha's.
Tensor colour_and_alpha_error_rows(const std::vector<Tensor>& rows, const std::vector<Tensor>&) {
  const Tensor d = rows[0] - rows[1];
  return dot(d, d * Tensor::from_values({1.0 / 3, 1.0 / 3, 1.0 / 3, 1.0}, {4}, d.dtype()));
}

Tensor colour_and_alpha_mse(const Tensor& rgba, const Tensor& target_rgba) {
  return map_rows_mean(colour_and_alpha_error_rows, {rgba, target_rgba});
}

Tensor Render::image() const { return slice(rgba, 2, 0, 3); }
Tensor Render::alpha() const { return slice(rgba, 2, 3, 4); }

Surface surface(const SurfaceMesh& mesh, const Tensor& positions, const Material& material) {
  Surface s;
  s.vertices = mesh.to_render(positions);
  s.normals = mesh.to_render(vertex_normals(positions, mesh.point_triangles));
  if (material.texture.defined()) {
    if (!mesh.uvs.defined()) throw ValueError("fit: a texture needs a mesh with uvs");
    s.texture = material.texture;
  } else {
    s.colours = mesh.to_render(material.point_colours);
  }
  return s;
}

Render render(const SurfaceMesh& mesh, const Surface& surface, const Tensor& view_projection, const Tensor& light,
              const Tensor& background, const RasterizeOptions& raster) {
  const int size = raster.width;
  const Tensor clip = transform_points(surface.vertices, view_projection);  // [R, 4]
  RasterizeOptions options = raster;
  options.derivatives = surface.texture.defined();  // the texture's level of detail
  const GBuffer gb = rasterize(clip, mesh.triangles, options);

  Tensor albedo;  // [H, W, 3]
  if (surface.texture.defined()) {
    const auto uv = interpolate_with_derivatives(mesh.uvs, gb, mesh.triangles);
    TextureOptions options;
    options.filter = Filter::Trilinear;
    albedo = texture(surface.texture, uv.values, options, uv.d_dx, uv.d_dy);
  } else {
    albedo = interpolate(surface.colours, gb, mesh.triangles);
  }
  const Tensor normal = interpolate(surface.normals, gb, mesh.triangles);

  // Coverage from the triangle ids (no gradient); the background fills the rest.
  const Tensor covered = greater(cast(gb.tri_id, DType::Float32), Tensor::scalar(0.0));
  const Tensor coverage = reshape(covered, {size, size, 1});
  const Tensor composited = shade_over_background(albedo, normal, coverage, light, background);
  // The coverage goes through antialias as a fourth channel: an alpha mask
  // whose silhouette gradient does not vanish where the surface's colour
  // happens to match the background.
  AntialiasOptions aa;
  aa.topology = mesh.topology;
  const Tensor rgba = antialias(concat({composited, coverage}, 2), gb, clip, mesh.triangles, aa);
  return {rgba, coverage};
}

Render render(const SurfaceMesh& mesh, const Tensor& positions, const Material& material, const Tensor& view_projection,
              const Tensor& light, const Tensor& background, const RasterizeOptions& raster) {
  return render(mesh, surface(mesh, positions, material), view_projection, light, background, raster);
}

}  // namespace fit
