// Attribute interpolation over a G-buffer, and its adjoint (no tape).
//
// Each covered pixel carries (tri_id, u, v) from rasterize_forward; its
// screen-space barycentrics are lambda = (1 - u - v, u, v) over the vertices
// (k0, k1, k2) of triangle tri_id - 1, and w_k is the clip w of vertex k
// (column 3 of clip), so gradients to w flow back into clip.
//
// Clipped triangles (a vertex with w <= 0 or z < -w: rasterize's homogeneous
// form, docs/rasterizer.md) take their perspective weights from the clip
// positions and the pixel centre e = (col + 0.5, row + 0.5, 1) instead:
//   q_k = F_k / D,  F_k = e . (V_k+1 x V_k+2),  D = V_0 . (V_1 x V_2),
//   V_k = (W/2 (x_k + w_k), H/2 (w_k - y_k), w_k),
// which equals lambda_k / w_k for the (u, v) rasterize stores but stays exact
// at w_k = 0 (where lambda_k = 0 carries no weight). In perspective mode their
// uv is not read, and their gradient goes to x, y, w of clip instead of uv.
#pragma once

#include <cstdint>

namespace gr::raster {

class TriangleGroups;  // raster/detail/triangle_groups.h

// Inputs of one interpolate call, shared by the forward, the adjoint and the
// derivatives. Image form (pixel_index null): the items are the width x
// height pixels, tri_id and uv hold H*W and H*W*2 values (tri_id 0 =
// background). Fragment form (pixel_index set): the items are `count`
// covered pixels (e.g. gr::Fragments), tri_id (count, each >= 1), uv
// (count x 2), pixel_index (count: the row-major pixel whose centre the
// clipped triangles' weights use). The kernels trust them (the op validates,
// ops/check.h): indices in range, tri_id in [0, num_tris] (fragments: from 1),
// pixel_index in [0, W*H), the image size within RasterSettings' limits.
template <class T>
struct InterpolateParams {
  const T* attr = nullptr;  // num_vertices x channels
  std::int64_t num_vertices = 0;
  std::int64_t channels = 0;
  const T* clip = nullptr;             // num_vertices x 4 (z, w read; x, y too for clipped triangles)
  const std::int32_t* tris = nullptr;  // num_tris x 3
  std::int64_t num_tris = 0;
  const std::int32_t* tri_id = nullptr;
  const T* uv = nullptr;
  int width = 0, height = 0;
  const std::int32_t* pixel_index = nullptr;  // fragment form only
  std::int64_t count = 0;                     // fragment form only
  bool perspective = true;
  const T* background = nullptr;  // image form: C values for tri_id 0 (null = zeros)
  // Adjoint only, optional: the items' grouping by triangle, shared with the
  // other adjoints over this tri_id (raster/detail/triangle_groups.h).
  TriangleGroups* groups = nullptr;
  // Pixels (image form) or fragments.
  std::int64_t items() const { return pixel_index ? count : static_cast<std::int64_t>(width) * height; }
};

// out (items x C): per item,
//   perspective: A = sum_k q_k A_k / s,  s = sum_k q_k,  q_k = lambda_k / w_k
//                (F_k / D on clipped triangles, above);
//   linear:      A = sum_k lambda_k A_k.
// Background pixels (tri_id 0) get `background`. The fragment form gives the
// image form's values at the fragments' pixels bit for bit (same loops, same
// summation order) when the fragments are in ascending pixel order.
template <class T>
void interpolate_forward(const InterpolateParams<T>& p, T* out);

// Where the adjoint accumulates: dL/dattr (N x C), dL/dclip (N x 4: column 3,
// plus columns 0 and 1 for the vertices of clipped triangles), dL/duv
// (items x 2); any may be null (not needed).
template <class T>
struct InterpolateGrads {
  T* attr = nullptr;
  T* clip = nullptr;
  T* uv = nullptr;
};

// Adjoint of interpolate_forward, ACCUMULATED (+=). With g = dL/dA (C values)
// at a covered item and q_k = lambda_k / w_k:
//   perspective: dL/dA_k += g q_k / s,
//                G_k = dL/dq_k = g . (A_k - A) / s,  dL/dlambda_k = G_k / w_k,
//                dL/dw_k -= G_k q_k / w_k;
//   clipped triangles (q_k = F_k / D): dL/dF_k = G_k / D (dL/dD = 0 as
//                sum_k G_k q_k = 0), dF_k/dV_k+1 = V_k+2 x e,
//                dF_k/dV_k+2 = e x V_k+1, then V -> x, y, w of clip;
//   linear:      dL/dA_k += g lambda_k,  dL/dlambda_k = g . A_k;
//   dL/du += dL/dlambda_1 - dL/dlambda_0,  dL/dv += dL/dlambda_2 - dL/dlambda_0.
// grad_out: items x C. Background pixels and items whose incoming
// gradient is zero contribute nothing. Sums are taken in float64 in a fixed
// order (each triangle's items in item order, then each vertex's triangles in
// the order of their first items) and added to the outputs once per vertex,
// so results are bit-identical for any thread count and triangle order.
// Divisions by s and w_k are guarded so the result stays finite.
template <class T>
void interpolate_backward(const InterpolateParams<T>& p, const T* grad_out, const InterpolateGrads<T>& grads);

// Screen-space derivatives of interpolate_forward's output (not differentiated
// further): d_dx, d_dy (H*W*C each) get dA/dx and dA/dy per pixel, x to the
// right and y DOWN, in units of one pixel. The screen barycentrics are affine
// in screen space, also for triangles crossing the near plane: with the
// homogeneous vertices V_k = (W/2 (x_k + w_k), H/2 (w_k - y_k), w_k),
// c_k = V_{k+1} x V_{k+2}, D = V_0 . c_0 and lambda_k = w_k (s . c_k) / D,
//   dlambda_k/dx = w_k c_k.x / D,  dlambda_k/dy = w_k c_k.y / D
// (constant per triangle). Then, with q_k = lambda_k / w_k = (s . c_k) / D,
// s = sum q_k:
//   perspective: dA/dx = sum_k (dq_k/dx) (A_k - A) / s,  dq_k/dx = c_k.x / D
//                (not divided by w_k, so exact at w_k = 0);
//   linear:      dA/dx = sum_k (dlambda_k/dx) A_k;
// likewise for y. Background pixels get zeros. Image form only.
template <class T>
void interpolate_derivatives(const InterpolateParams<T>& p, T* d_dx, T* d_dy);

}  // namespace gr::raster
