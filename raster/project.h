// Projection kernels: the perspective divide (clip -> NDC) and the viewport
// transform (NDC -> screen pixels), each with its adjoint. Plain arrays, no
// tape. Conventions (OpenGL): ndc = (x/w, y/w, z/w); xs = W/2 (1 + x_ndc),
// ys = H/2 (1 - y_ndc), so row 0 is the top row and pixel (i, j) has its
// centre at (i + 0.5, j + 0.5).
#pragma once

#include <cstdint>

namespace gr::raster {

// ndc (N x 3) = (x/w, y/w, z/w) of clip (N x 4, row-major).
// Throws ValueError naming the vertex if some w is exactly 0: the caller
// should clip first (rasterize does, so it never divides by w <= 0).
template <class T>
void wdivide_forward(const T* clip, std::int64_t num_vertices, T* ndc);

// Adjoint of wdivide_forward, accumulated into grad_clip (N x 4):
//   dL/dx += g_x / w,  dL/dy += g_y / w,  dL/dz += g_z / w,
//   dL/dw -= (g_x x + g_y y + g_z z) / w^2.
// Vertices whose three incoming gradients are zero are skipped; a non-zero
// gradient at w == 0 throws ValueError.
template <class T>
void wdivide_backward(const T* clip, std::int64_t num_vertices, const T* grad_ndc, T* grad_clip);

// screen (N x 2) = (W/2 (1 + x_ndc), H/2 (1 - y_ndc)) of ndc (N x 3).
template <class T>
void viewport_forward(const T* ndc, std::int64_t num_vertices, int width, int height, T* screen);

// Adjoint of viewport_forward, accumulated into grad_ndc (N x 3; z untouched):
//   dL/dx_ndc += W/2 g_xs,  dL/dy_ndc -= H/2 g_ys.
template <class T>
void viewport_backward(std::int64_t num_vertices, int width, int height, const T* grad_screen,
                       T* grad_ndc);

// viewport_backward then wdivide_backward, fused per vertex and computed in
// double, for kernels that accumulate screen-space gradients in double:
// grad_screen (N x stride, screen x, y and, if stride == 3, z_ndc) ->
//   g_ndc = (W/2 g_xs, -H/2 g_ys, g_z),  dL/d(x, y, z) += g_ndc / w,
//   dL/dw -= (g_ndc . (x, y, z)) / w^2,
// accumulated into grad_clip (N x 4) and clamped to T's finite range once at
// the end: for |w| -> 0 in float32 the gradient is large but finite where
// the float kernels above would overflow to Inf. Vertices with zero incoming
// gradient are skipped; the others must have w > 0 (callers pass only
// vertices in front of the near plane).
// y_up (RasterSettings::y_up): the screen positions came from clip with y
// negated (ys = H/2 (1 + y_ndc)), so g_ndc.y = +H/2 g_ys; clip is the caller's
// (unnegated) array. Bit for bit the y_up = false result on the negated clip,
// with the y gradient negated.
template <class T>
void screen_to_clip_backward(const T* clip, std::int64_t num_vertices, int width, int height,
                             const double* grad_screen, int stride, T* grad_clip, bool y_up = false);

}  // namespace gr::raster
