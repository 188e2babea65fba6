// Analytic silhouette antialiasing as an op: a shaded image, its G-buffer and
// the clip-space positions -> the image with silhouette edges blended, and
// gradients for the silhouette vertices that coverage alone never gives.
//
// Like rasterize, the op takes clip-space positions: it projects them with the
// same w-divide and viewport as rasterize, and its adjoint chains through the
// viewport and w-divide adjoints into dL/dclip, so gradients reach model
// vertices and camera parameters through transform_points / matmul.
#pragma once

#include <memory>

#include "autodiff/base/tensor.h"
#include "ops/render/rasterize.h"
#include "raster/antialias.h"
#include "raster/visibility_antialias.h"

namespace gr {

// Edge adjacency for the silhouette test, built once per mesh.
using AntialiasTopology = std::shared_ptr<const raster::EdgeTopology>;

// triangles [M, 3] int32. positions: optional [N, D] float tensor (e.g. the
// model-space positions); vertices with equal rows are welded, so duplicated
// seam vertices do not make their edges look like silhouettes. Without
// positions any index >= 0 is accepted, and the memory taken grows with M,
// never with the largest index (checked against the memory budget).
AntialiasTopology antialias_topology(const Tensor& triangles, const Tensor& positions = Tensor());

struct AntialiasOptions {
  // Precomputed antialias_topology(triangles, ...). Empty: built from the
  // triangles, welding vertices with equal clip-space rows, and kept for the
  // next calls on the same triangle tensor (unwritten since) while the same
  // vertices have equal rows: those calls check the weld (O(N)) instead of
  // building it again, and a device keeps its upload.
  AntialiasTopology topology;
  raster::AntialiasStats* stats = nullptr;  // if set, receives the pair counts
  // nvdiffrast's pos_gradient_boost: the gradient to clip is multiplied by
  // this factor (faster silhouette motion); the image gradient and the
  // forward are unchanged. Finite; 1 = the plain adjoint.
  double pos_gradient_boost = 1.0;
  // Blend every visibility boundary, intersection curves included
  // (visibility_antialias, ops/render/visibility_antialias.h), not only the
  // silhouettes found from the topology.
  bool visibility = false;
  raster::VisibilityAntialiasStats* visibility_stats = nullptr;  // with visibility: its pair counts
};

// image [H, W, C] (same dtype as clip), gbuffer = rasterize(clip, triangles,
// {W, H}), clip [N, 4], triangles [M, 3] int32 -> [H, W, C].
// For each horizontally or vertically neighbouring pixel pair with different
// tri_id, the segment from the front pixel's centre ("inside") to the other
// ("outside") is followed from the front triangle across interior edges; the
// first silhouette edge (boundary, non-manifold, or its neighbour folds onto
// the same screen side) it crosses, if any before the outside centre, crosses at
// t = E(inside) / (E(inside) - E(outside)). The pair blends only if its axis
// owns that edge: horizontal pairs own edges with |dy| >= |dx| (screen space,
// closer to vertical), vertical pairs those with |dx| > |dy|, so every edge
// crossing is blended exactly once, across the axis most perpendicular to it
// (blended colours then approximate the pixel's covered area to first order,
// and d(image)/d(edge position) the covered-area rate); then
//   t > 1/2:  out[outside] += (t - 1/2) (c[inside] - c[outside])
//   t <= 1/2: out[inside]  += (1/2 - t) (c[outside] - c[inside]).
// Adjoints: to the image (identity plus the blend weights) and, through
// dL/dt = g[written pixel] . (c[inside] - c[outside]) and the quotient rule on
// E, to the screen positions of the edge's two vertices, then the viewport and
// w-divide adjoints to clip (raster/antialias.h states them). The G-buffer gets
// no gradient. Bit-identical for any thread count.
Tensor antialias(const Tensor& image, const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                 const AntialiasOptions& options = {});

}  // namespace gr
