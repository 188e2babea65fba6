// nvdiffrast's attribute interpolation and its adjoint, on plain arrays (no
// tape): attributes are blended with the barycentrics stored in a G-buffer of
// nvdiffrast's layout (raster/barycentric_gbuffer.h), which are already
// perspective-correct, so the blend is linear:
//   A = b0 A_0 + b1 A_1 + (1 - b0 - b1) A_2,
// and, from rast_db = (db0/dx, db0/dy, db1/dx, db1/dy),
//   dA/dx = db0/dx (A_0 - A_2) + db1/dx (A_1 - A_2)   (likewise y).
#pragma once

#include <cstdint>

namespace gr::raster {

class TriangleGroups;  // raster/detail/triangle_groups.h

// Inputs of one image, shared by the forward and the adjoint. The kernels
// trust them (the caller validates): the ids in rast's channel 3 (or tri_id)
// are integers in [0, num_tris], indices in [0, num_vertices), diff in [0, channels).
template <class T>
struct BarycentricInterpolateParams {
  const T* attr = nullptr;  // num_vertices x channels
  std::int64_t num_vertices = 0;
  std::int64_t channels = 0;
  const std::int32_t* tris = nullptr;  // num_tris x 3
  std::int64_t num_tris = 0;
  const T* rast = nullptr;  // H*W*4: b0, b1, z/w, id (0 = background)
  std::int64_t pixels = 0;  // H*W
  // Derivatives (optional): rast_db (H*W*4) and the channels to differentiate.
  const T* rast_db = nullptr;
  const std::int32_t* diff = nullptr;
  std::int64_t num_diff = 0;
  // Or the C++ GBuffer's planes: rast = its uv (H*W*2: b0, b1; rast_stride 2)
  // and the ids from tri_id (H*W int32, 0 = background) instead of channel 3.
  std::int64_t rast_stride = 4;
  const std::int32_t* tri_id = nullptr;
  // Adjoint only, optional (with tri_id): the pixels' grouping by triangle,
  // shared with the other adjoints over this tri_id (raster/detail/triangle_groups.h).
  TriangleGroups* groups = nullptr;
};

// out: pixels x channels (background 0); out_da: pixels x 2 num_diff as
// (dA/dx, dA/dy) per selected channel, or null.
template <class T>
void barycentric_interpolate_forward(const BarycentricInterpolateParams<T>& p, T* out, T* out_da);

// Where the adjoint accumulates (+=); each may be null.
template <class T>
struct BarycentricInterpolateGrads {
  T* attr = nullptr;     // num_vertices x channels
  T* rast = nullptr;     // pixels x rast_stride (channels 0 and 1)
  T* rast_db = nullptr;  // pixels x 4
};

// Adjoint. With g = dL/dA and h = (dL/d(dA/dx), dL/d(dA/dy)) per pixel:
//   dL/dA_k += b_k g + (db_k/dx h_x + db_k/dy h_y) on the selected channels
//   (b_2 = 1 - b0 - b1, db_2 = -db0 - db1),
//   dL/db_k += g . (A_k - A_2) (k = 0, 1),  dL/d(db_k/dx) += h_x . (A_k - A_2).
// grad_out: pixels x channels; grad_da: pixels x 2 num_diff or null.
// Per-vertex sums: pixels grouped by triangle and summed per corner in pixel
// order (float64), then each vertex's corners in the order of their
// triangles' first pixels (bit-identical for any thread count).
template <class T>
void barycentric_interpolate_backward(const BarycentricInterpolateParams<T>& p, const T* grad_out,
                                      const T* grad_da, const BarycentricInterpolateGrads<T>& grads);

}  // namespace gr::raster
