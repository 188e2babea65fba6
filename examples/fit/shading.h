// Rendering one view of a mesh with Lambert shading, every step a tensor op,
// so a loss on the image differentiates back to the vertex positions, the
// vertex colours or texture, and the camera:
//   clip -> rasterize -> interpolate (colour or uv -> texture, normal)
//   -> Lambert -> composite over the background -> antialias.
// The antialias step is what lets the loss move silhouettes. This is the part
// to copy into your own program.
#pragma once

#include "autodiff/tensor.h"
#include "examples/fit/geometry.h"

namespace fit {

using gr::Tensor;

// Where the surface colour comes from: vertex colours (one per point) or a
// texture sampled at the mesh's uvs (trilinear, repeat).
struct Material {
  Tensor point_colours;  // [P, 3], or undefined
  Tensor texture;        // [Ht, Wt, 3], used when defined (the mesh needs uvs)
};

struct Render {
  Tensor image;     // [H, W, 3] shaded, composited over the background, antialiased
  Tensor coverage;  // [H, W, 1] 1 where a triangle covers the pixel centre, else 0 (no gradient)
  Tensor alpha;     // [H, W, 1] the coverage antialiased like the image (differentiable at silhouettes)
};

// albedo * (ambient + (1 - ambient) * max(n . l, 0)), per pixel.
Tensor lambert(const Tensor& albedo, const Tensor& normal, const Tensor& light, double ambient = 0.2);

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
// -> a size x size render of `surface`.
Render render(const SurfaceMesh& mesh, const Surface& surface, const Tensor& view_projection, const Tensor& light,
              const Tensor& background, int size);

// One view straight from the positions: render(mesh, surface(mesh, positions, material), ...).
Render render(const SurfaceMesh& mesh, const Tensor& positions, const Material& material, const Tensor& view_projection,
              const Tensor& light, const Tensor& background, int size);

}  // namespace fit
