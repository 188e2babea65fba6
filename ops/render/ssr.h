// Screen-space reflections as a differentiable deferred pass:
//   1. ssr_gbuffer: rasterize once, interpolate view-space position and normal
//      (perspective-correct) and colour per pixel (all ordinary ops: gradients
//      reach vertex colours, positions and the projection as usual);
//   2. ssr_trace: find per pixel where the mirror ray meets the depth buffer with
//      one of the tracers of raster/ssr.h (view-space march, McGuire-Mara DDA or
//      the dense reference). This is a STOP-GRADIENT: hit flag, hit position and
//      distances come back as constants (not recorded on the tape);
//   3. ssr_composite: reflected = bilinear sample of the colour buffer at the hit
//      (gr::texture, Clamp) x confidence x reflectivity, lerped with the base
//      colour. Confidence = hit x edge fade x distance fade, the fades computed
//      with tensor ops from tensor parameters, so gradients reach the colour
//      buffer (both as base and as reflected colour), the reflectivity and the
//      four fade parameters.
//
// Why the hit search gets no gradient: the hit is the first sample along the ray
// whose depth falls inside a band behind the depth buffer, a discrete choice of
// pixel; the search's output is piecewise constant in the G-buffer (with the
// binary search, piecewise constant at a finer scale), so its derivative is 0
// almost everywhere and undefined (a jump) at the rest. A "gradient" through it
// would either be zero or need a smoothed (soft) hit model. The ray-surface
// intersection point does move smoothly with the geometry inside one surface,
// but recovering that derivative needs an implicit-function step through the
// depth buffer's interpolation that the search does not perform; we leave it out
// (as texture's LOD). Gradients w.r.t. the hit uv through the bilinear sample
// are likewise not propagated (the uv tensor does not require grad).
//
// Usage:
//   auto vs = ssr_view_space(mesh_positions, mesh_normals, view);      // camera space
//   SsrGBuffer g = ssr_gbuffer(vs.positions, vs.normals, colours, tris, proj, {W, H});
//   Tensor shaded = ...shading of g.colour, g.normal, g.position...;
//   SsrTrace t = ssr_trace(g, proj, options);                           // constants
//   SsrComposite c = ssr_composite(shaded, t, reflectivity, ssr_fade(options));
#pragma once

#include "autodiff/base/tensor.h"
#include "ops/render/rasterize.h"
#include "raster/ssr.h"

namespace gr {

using raster::EdgeFade;
using raster::SsrOptions;
using raster::SsrTracer;

struct ViewSpaceMesh {
  Tensor positions;  // [N, 3] view-space positions
  Tensor normals;    // [N, 3] view-space normals (rotated only: view must be rigid)
};
// positions, normals [N, 3] world space; view [4, 4] rigid (e.g. look_at).
// Composite of transform_points, slice and matmul (differentiable).
ViewSpaceMesh ssr_view_space(const Tensor& positions, const Tensor& normals, const Tensor& view);

struct SsrGBufferOptions {
  int width = 0;
  int height = 0;
  bool back_faces = false;  // also rasterize back faces for real thickness (closed objects)
};

struct SsrGBuffer {
  Tensor position;   // [H, W, 3] view-space position (0 on background)
  Tensor normal;     // [H, W, 3] unit view-space normal (0 on background)
  Tensor colour;     // [H, W, C] interpolated vertex colours (0 on background)
  Tensor mask;       // [H, W] int32 tri_id: 0 = background
  Tensor back_z;     // [H, W] view z of the nearest back face (back_faces only; 0 where none)
  Tensor back_mask;  // [H, W] int32 back-face tri_id (back_faces only)
  GBuffer raster;    // the front G-buffer
};

// view_positions, view_normals [N, 3], colours [N, C] (same float dtype),
// triangles [M, 3] int32, projection [4, 4] (OpenGL, e.g. perspective()).
// Composite of transform_points, rasterize, interpolate (perspective-correct) and
// normalize, so every output is differentiable the usual way.
SsrGBuffer ssr_gbuffer(const Tensor& view_positions, const Tensor& view_normals, const Tensor& colours,
                       const Tensor& triangles, const Tensor& projection, const SsrGBufferOptions& options);

// Per-pixel result of the hit search: constants (stop-gradient), dtype of position.
struct SsrTrace {
  int width = 0, height = 0;
  Tensor hit;            // [H, W, 1] 1 = hit, 0 = none
  Tensor hit_xy;         // [H, W, 2] screen position of the hit in pixels (screen centre if none)
  Tensor hit_uv;         // [H, W, 2] the same as texture uv: (x / W, 1 - y / H) (docs/texture.md)
  Tensor hit_distance;   // [H, W, 1] view-space distance from the pixel's point to the hit (0 if none)
  Tensor hit_position;   // [H, W, 3] view-space hit point (0 if none)
  Tensor edge_fade;      // [H, W, 1] plain fades at the options' parameters (0 if none)
  Tensor distance_fade;  // [H, W, 1]
  raster::SsrStats stats;
};

// position, normal [H, W, 3] float32/float64, mask [H, W] int32 (non-zero =
// covered), projection [4, 4]; back_z [H, W] and back_mask [H, W] int32 optional.
// Throws ShapeError / DTypeError naming the argument, ValueError for bad options.
SsrTrace ssr_trace(const Tensor& position, const Tensor& normal, const Tensor& mask, const Tensor& projection,
                   const SsrOptions& options, const Tensor& back_z = {}, const Tensor& back_mask = {});
SsrTrace ssr_trace(const SsrGBuffer& gbuffer, const Tensor& projection, const SsrOptions& options);

// Fade parameters as tensors (one element each), so gradients can reach them.
struct SsrFade {
  EdgeFade form = EdgeFade::Circular;
  Tensor edge_distance, edge_exponent, fade_distance, fade_exponent;
};
// Constants from options (dtype given); set_requires_grad() on any to learn it.
SsrFade ssr_fade(const SsrOptions& options, DType dtype = DType::Float32);

// Tensor-op fades over a trace, [H, W, 1] (a, b = hit_xy / (W, H) constants):
//   circular: clamp(1 - r^edge_exponent, 0, 1),  r = 2 |(a, b) - 1/2|
//     d/d(exponent) = -r^e ln r inside the clamp (0 at r = 0);
//   vignette: clamp((edge_distance a(1-a) b(1-b))^edge_exponent, 0, 1)
//     d/d(distance) = e v^(e-1) a(1-a)b(1-b), d/d(exponent) = v^e ln v;
//   distance: clamp(1 - (d / fade_distance)^fade_exponent, 0, 1)
//     d/dF = e (d/F)^e / F, d/de = -(d/F)^e ln(d/F).
// Outside the clamp range the gradient is 0 (clamp passes it at the bounds).
Tensor ssr_edge_fade(const SsrTrace& trace, const SsrFade& fade);
Tensor ssr_distance_fade(const SsrTrace& trace, const SsrFade& fade);
// hit x edge fade x distance fade, [H, W, 1].
Tensor ssr_confidence(const SsrTrace& trace, const SsrFade& fade);

struct SsrComposite {
  Tensor image;       // [H, W, C] colour + reflectivity conf (sample - colour)
  Tensor reflection;  // [H, W, C] raw reflection: sample x confidence (unblurred)
  Tensor confidence;  // [H, W, 1]
};
// colour [H, W, C] (the shaded image; also the buffer the reflection samples),
// reflectivity broadcastable to [H, W, 1] (e.g. [H, W, 1] or [1]).
// sample = texture(colour, hit_uv, Bilinear, Clamp); a = reflectivity * confidence;
// image = colour + a (sample - colour).
// Adjoints (with g = dL/dimage): dL/dcolour = g (1 - a) + texture adjoint of g a;
// dL/da = g . (sample - colour), then to reflectivity and through the fades.
SsrComposite ssr_composite(const Tensor& colour, const SsrTrace& trace, const Tensor& reflectivity,
                           const SsrFade& fade);

}  // namespace gr
