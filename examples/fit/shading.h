// Rendering one view of a mesh with Lambert shading, every step a tensor op,
// so a loss on the image differentiates back to the vertex positions, the
// vertex colours or texture, and the camera:
//   clip -> rasterize -> interpolate (colour or uv -> texture, normal)
//   -> Lambert -> composite over the background -> antialias.
// The antialias step is what lets the loss move silhouettes. This is the part
// to copy into your own program.
#pragma once

#include <vector>

#include "autodiff/base/tensor.h"
#include "examples/fit/geometry.h"
#include "ops/render/rasterize.h"

namespace fit {

using gr::RasterizeOptions;
using gr::Tensor;

// Where the surface colour comes from: vertex colours (one per point) or a
// texture sampled at the mesh's uvs (trilinear, repeat).
struct Material {
  Tensor point_colours;  // [P, 3], or undefined
  Tensor texture;        // [Ht, Wt, 3], used when defined (the mesh needs uvs)
};

struct Render {
  // [H, W, 4]: the colour (shaded, composited over the background) and the
  // coverage as alpha, both antialiased (so differentiable at silhouettes).
  Tensor rgba;
  Tensor coverage;  // [H, W, 1] 1 where a triangle covers the pixel centre, else 0 (no gradient)
  Tensor image() const;  // [H, W, 3] the colour channels of rgba
  Tensor alpha() const;  // [H, W, 1] its alpha channel
};

// albedo * (ambient + (1 - ambient) * max(n . l, 0)), per pixel.
Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light, double ambient = 0.2);

// lambert(albedo, normalize(normal), light) where coverage is 1, background
// where it is 0: albedo, normal [H, W, 3], coverage [H, W, 1], light and
// background [3]. One fused pass over the pixels (ops/tensor/map_rows.h), the same
// bits as the tensor ops one by one.
Tensor shade_over_background(const Tensor& albedo, const Tensor& normal, const Tensor& coverage, const Tensor& light,
                             const Tensor& background);

// mean over pixels and channels of (rgb - target rgb)^2, plus the same of
// alpha: the fit's image loss, as one fused pass (rgba, target_rgba [H, W, 4]).
Tensor colour_and_alpha_mse(const Tensor& rgba, const Tensor& target_rgba);

// Their per-pixel functions (gr::RowFunction: rows = the per-pixel inputs in
// the order above, shared = light and background), e.g. for map_rows_fuses.
Tensor shade_over_background_rows(const std::vector<Tensor>& rows, const std::vector<Tensor>& shared);
Tensor colour_and_alpha_error_rows(const std::vector<Tensor>& rows, const std::vector<Tensor>& shared);

// What every view of a mesh shares, per render vertex: the positions, the
// unit normals (computed on the welded points, so a uv seam stays smooth) and
// the colours, or the texture. Computed once and rendered from many views.
struct Surface {
  Tensor vertices;  // [R, 3]
  Tensor normals;   // [R, 3]
  Tensor colours;   // [R, 3], or undefined when the material has a texture
  Tensor texture;   // the material's texture, or undefined
};

// positions [P, 3] (the mesh's points, moved) -> the surface the views render.
Surface surface(const SurfaceMesh& mesh, const Tensor& positions, const Material& material);

// view_projection [4, 4], light [3] (unit, towards the light), background [3]
// -> a raster.width x raster.height render of `surface` (square: the
// targets' and the snapshots' images are).
Render render(const SurfaceMesh& mesh, const Surface& surface, const Tensor& view_projection, const Tensor& light,
              const Tensor& background, const RasterizeOptions& raster);

// One view straight from the positions: render(mesh, surface(mesh, positions, material), ...).
Render render(const SurfaceMesh& mesh, const Tensor& positions, const Material& material, const Tensor& view_projection,
              const Tensor& light, const Tensor& background, const RasterizeOptions& raster);

}  // namespace fit
