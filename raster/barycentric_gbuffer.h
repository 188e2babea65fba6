// nvdiffrast's G-buffer layout and its adjoint, on plain arrays (no tape):
// per pixel rast = (b0, b1, z/w, id) with perspective-correct barycentrics of
// vertices 0 and 1, and rast_db = (db0/dx, db0/dy, db1/dx, db1/dy).
//
// Coverage comes from rasterize_forward (tri_id); the values are recomputed
// here in the homogeneous form, which is exact for every triangle, also one
// crossing the near plane (docs/python.md, "rasterize"): with the pixel
// centre e = (x + 0.5, y + 0.5, 1), V_k = (W/2 (x_k + w_k), H/2 (w_k - y_k),
// w_k), c_k = V_k+1 x V_k+2, a_k = e . c_k, S = a_0 + a_1 + a_2, C = sum c_k,
// D = V_0 . c_0:
//   b_k = a_k / S,  z/w = sum_k a_k z_k / D,
//   db_k/dx = (c_k.x S - a_k C.x) / S^2,  db_k/dy = (c_k.y S - a_k C.y) / S^2,
// x to the right and y down the rows, in pixels. As nvdiffrast, b0 and b1 are
// clamped to [0, 1] with b0 + b1 <= 1 and z/w to [-1, 1]; the adjoint treats
// the clamps as the identity (they act only on rounding at triangle edges).
#pragma once

#include <cstdint>

namespace gr::raster {

class TriangleGroups;  // raster/detail/triangle_groups.h

// Inputs of one image, shared by the forward and the adjoint. The kernels
// trust them (the caller validates): indices in [0, num_vertices), ids in
// range, clip finite, the size within RasterSettings' limits.
template <class T>
struct BarycentricGBufferParams {
  const T* clip = nullptr;  // num_vertices x 4
  std::int64_t num_vertices = 0;
  const std::int32_t* tris = nullptr;  // num_tris x 3
  std::int64_t num_tris = 0;
  int width = 0, height = 0;
  // Row 0 is the bottom row (RasterSettings::y_up; the coverage must come
  // from a y_up rasterize): every formula here reads y negated, so
  // V_k = (W/2 (x_k + w_k), H/2 (w_k + y_k), w_k), and the adjoint's y is
  // negated back. Bit for bit the y_up = false result on a y-negated clip.
  bool y_up = false;
  // Adjoint only, optional: the coverage as int32 ids (H*W, 1-based, 0 =
  // background, indexing tris) instead of rast's id channel, which the
  // adjoint then does not read (rast may be null). Ids beyond 2^24 are exact
  // only here in float32.
  const std::int32_t* tri_id = nullptr;
  // Adjoint only, optional (with tri_id): the pixels' grouping by triangle,
  // shared with the other adjoints over this tri_id (raster/detail/triangle_groups.h).
  TriangleGroups* groups = nullptr;
};

// Forward. tri_id (H*W, 0 = background) is rasterize_forward's output for
// the triangles tris + 3 id_offset (nvdiffrast's range mode; 0 otherwise);
// rast's id channel holds id_offset + tri_id, so ids index `tris`.
// rast: H*W*4; db: H*W*4 or null. Background pixels are all zero.
template <class T>
void barycentric_gbuffer_forward(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id,
                                 std::int64_t id_offset, T* rast, T* db);

// The forward into the C++ GBuffer's planes (ops/render/rasterize.h), ids
// indexing `tris` (no offset): uv (H*W*2: b0, b1) and depth (H*W: z/w on
// covered pixels, background_depth on the background) get rast's channels 0
// to 2 bit for bit, db (H*W*4 or null) the same as above.
template <class T>
void barycentric_gbuffer_forward_planes(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, T* uv,
                                        T* depth, T background_depth, T* db);

// Adjoint, ACCUMULATED (+=) into grad_clip (num_vertices x 4), for the
// coverage stored in rast's id channel or p.tri_id (ids relative to `tris`). grad_rast:
// H*W*4 (the id channel is ignored); grad_db: H*W*4 or null. Per pixel, with
// g_k the gradients of b_k (g_2 = 0), g_z of z/w and h the gradients of the
// derivatives:
//   dL/da_k = (g_k - sum_j g_j b_j) / S + g_z z_k / D  + (from the derivatives:
//   dL/dc_k.d += h_k.d / S, dL/dC.d -= h_k.d a_k / S^2, dL/da_k -= h_k.d C.d / S^2,
//   dL/dS += (2 h_k.d a_k C.d / S - h_k.d c_k.d) / S^2, then dL/da_k += dL/dS),
//   dL/dz_k = g_z a_k / D,  dL/dD = -g_z (z/w) / D,
//   dL/dc_k += dL/da_k e + dL/dC,  dL/dV_j += dL/dD c_j,
//   c_k = V_k+1 x V_k+2: dL/dV_k+1 += V_k+2 x dL/dc_k, dL/dV_k+2 += dL/dc_k x V_k+1,
// then V -> clip. Everything after dL/dc_k, dL/dD and dL/dz_k is linear with
// per-triangle constants, so those 13 cotangents are summed per triangle in
// pixel order (float64) and the rest runs once per triangle; then per vertex
// over its triangles in the order of their first pixels, so the result is
// bit-identical for any thread count.
template <class T>
void barycentric_gbuffer_backward(const BarycentricGBufferParams<T>& p, const T* rast, const T* grad_rast,
                                  const T* grad_db, T* grad_clip);

// The same adjoint with rast's gradients as the GBuffer's planes (coverage
// from p.tri_id, required): grad_uv H*W*2 (b0, b1) and grad_depth H*W (z/w),
// either may be null (zero), so the op's adjoint needs no H*W*4 copy.
template <class T>
void barycentric_gbuffer_backward_planes(const BarycentricGBufferParams<T>& p, const T* grad_uv, const T* grad_depth,
                                         const T* grad_db, T* grad_clip);

}  // namespace gr::raster
