// Visibility antialiasing as an op (issue 13 item 2): like antialias, but the
// boundary between two neighbouring pixels is located from BOTH visible
// surfaces, so intersection curves (where two surfaces cut through each
// other, which are no mesh edges) are blended and get gradients too, sent to
// the vertices of both triangles. Silhouettes against the background,
// occlusion boundaries and edges exposed by culling are treated as antialias
// does, except that an occluder's own silhouette is found when the surface
// behind it is the nearer one at its pixel centre.
//
// The forward image is the point-sampled image with first-order analytic
// coverage at every visibility boundary: each boundary crossing between two
// pixel centres, on the axis most perpendicular to it, moves the colour of
// the pixel on the smaller side towards its neighbour's by the distance of
// the crossing from the midpoint (the pixel's covered area to first order).
// Where no boundary is found (e.g. interior mesh edges) pixels are unchanged.
// Design, formulas and measurements: docs/visibility_antialias.md.
#pragma once

#include "autodiff/base/tensor.h"
#include "ops/render/antialias.h"
#include "ops/render/rasterize.h"
#include "raster/visibility_antialias.h"

namespace gr {

struct VisibilityAntialiasOptions {
  // Precomputed antialias_topology(triangles, ...). Empty: welded from the
  // clip rows and kept between calls, as antialias's (AntialiasOptions).
  AntialiasTopology topology;
  raster::VisibilityAntialiasStats* stats = nullptr;  // if set, receives the pair counts
  double pos_gradient_boost = 1.0;  // as antialias's: scales the gradient to clip
};

// image [H, W, C] (same dtype as clip), gbuffer = rasterize(clip, triangles,
// {W, H}), clip [N, 4], triangles [M, 3] int32 -> [H, W, C]. Per pixel pair
// with different tri_id, the boundary (raster/visibility_antialias.h):
//   - a silhouette edge of the front surface, or, if that surface goes on
//     hidden under the other, a silhouette edge of the other (the occluder):
//     t = E(inside) / (E(inside) - E(outside)) with E the edge function;
//   - if both surfaces go on under each other, their intersection: each
//     surface is followed along the segment, and on the first piece where the
//     depth difference d = z_F - z_B changes sign, with d0, d1 the difference
//     of the two triangles' depth planes there (z_ndc, affine in screen
//     space) at the two centres, t = d0 / (d0 - d1);
// blended once per crossing on the owning axis, as antialias:
//   t > 1/2:  out[outside] += (t - 1/2) (c[inside] - c[outside])
//   t <= 1/2: out[inside]  += (1/2 - t) (c[outside] - c[inside]).
// Adjoints: to the image (identity plus blend weights) and, through
// dL/dt = g[written pixel] . (c[inside] - c[outside]), to the screen x, y of
// an edge's two vertices, or to the screen x, y and z_ndc of both triangles'
// six vertices (dz(c)/dz_k = lambda_k(c), dz(c)/d(x_k, y_k) = -(a, b)
// lambda_k(c) with (a, b) the plane's slopes), then through the viewport and
// w-divide adjoints to clip. The G-buffer gets no gradient. Bit-identical for
// any thread count; no NaN/Inf for coplanar or nearly parallel faces
// (crossings of depth steps under 1e-12 are ignored; quotients guarded).
// Equal to antialias(image, gbuffer, clip, triangles, {.visibility = true,
// ...}); batches: antialias_batch with options.visibility.
Tensor visibility_antialias(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                            const VisibilityAntialiasOptions& options = {});

}  // namespace gr
