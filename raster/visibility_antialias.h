// Antialiasing at every visibility boundary (issue 13 item 2) and its
// adjoint, on plain arrays (no tape): silhouettes against the background,
// occlusion boundaries, edges exposed by culling AND intersection curves
// where two surfaces cut through each other.
//
// For every horizontally or vertically neighbouring pixel pair whose
// triangle ids differ, the boundary between the two centres is located from
// the geometry of both visible surfaces:
//   1. follow the front surface (smaller (depth, id); background behind
//      everything) from its centre towards the other across interior edges
//      (as raster/antialias.h does): a silhouette edge crossed first is the
//      boundary; reaching the other pixel's triangle means one surface (none);
//   2. if the front surface continues, hidden, to the other centre, follow the
//      other surface back: a silhouette edge crossed first is the boundary (it
//      is the occluder);
//   3. if both surfaces continue under each other, they interpenetrate: the
//      boundary is where their depths are equal. z_ndc is affine in screen
//      space over each triangle, so along the segment each surface's depth is
//      piecewise affine (the walks of steps 1 and 2 give its triangles); on
//      the first piece where the depth difference d = z_F - z_B goes from
//      <= 0 to >= 0, with F' and B' the two triangles there and d0, d1 the
//      difference of their planes at the two centres, t = d0 / (d0 - d1).
// The crossing blends the two colours one-sided as antialias does, on the
// pairs of the axis most perpendicular to the boundary. Formulas and the
// reasons: docs/visibility_antialias.md.
#pragma once

#include <cstdint>
#include <vector>

#include "raster/antialias.h"

namespace gr::raster {

// The inputs are antialias's (image, channels, size, G-buffer, clip,
// triangles, topology), trusted as there; the adjoint reads image, channels,
// width, height, clip and num_vertices.
template <class T>
using VisibilityAntialiasParams = AntialiasParams<T>;

enum class BoundaryKind : std::int32_t {
  Edge = 0,          // a silhouette edge v[0]-v[1] of the surface at `inside`
  Intersection = 1,  // planes of triangle (v[0], v[1], v[2]) of `inside`'s surface and (v[3], v[4], v[5]) of `outside`'s
};

// One blended pixel pair, in the order the forward applied them (row-major by
// the pair's top/left pixel, then horizontal before vertical).
struct VisibilityPair {
  std::int64_t inside;   // the pixel whose surface ends (edge) or is in front (intersection) on its side
  std::int64_t outside;  // its neighbour
  BoundaryKind kind;
  std::int32_t v[6];     // vertex indices (edge: v[0], v[1])
  double t;              // crossing position along inside -> outside centre, in [0, 1]
};

struct VisibilityAntialiasStats {
  std::int64_t candidate_pairs = 0;      // neighbouring pixels with different tri_id
  std::int64_t edge_pairs = 0;           // blended at a silhouette edge
  std::int64_t intersection_pairs = 0;   // blended at an intersection of two surfaces
};

// out: H x W x C row-major (may not alias image). Per blended pair, with t
// the crossing position from inside:
//   t > 1/2:  out[outside] += (t - 1/2) (image[inside] - image[outside])
//   t <= 1/2: out[inside]  += (1/2 - t) (image[outside] - image[inside])
// (every other pixel is copied). Pairs are appended to *pairs if non-null.
template <class T>
void visibility_antialias_forward(const VisibilityAntialiasParams<T>& p, T* out,
                                  std::vector<VisibilityPair>* pairs = nullptr,
                                  VisibilityAntialiasStats* stats = nullptr);

// Adjoint of visibility_antialias_forward, ACCUMULATED (+=) into `grads`
// (either pointer may be null). With g = grad_out and per pair the written
// pixel `target`, the other `source`, w = |t - 1/2|:
//   dL/dimage += g;  dL/dimage[target] -= w g[target];  dL/dimage[source] += w g[target]
//   dL/dt = g[target] . (image[inside] - image[outside])
// Edge pairs: t = E_i / (E_i - E_o) with the screen edge function E of
// v[0]-v[1], as in antialias_backward (screen x, y of both vertices).
// Intersection pairs: t = d0 / (d0 - d1), d_j = z_F(c_j) - z_B(c_j), each
// plane z(c) = sum_k lambda_k(c) z_k over screen barycentrics lambda_k:
//   dt/dd0 = -d1 / (d0 - d1)^2,  dt/dd1 = d0 / (d0 - d1)^2,
//   dz(c)/dz_k = lambda_k(c),  dz(c)/dx_k = -a lambda_k(c),  dz(c)/dy_k = -b lambda_k(c)
// (a, b = the plane's screen slopes dz/dx, dz/dy; d takes F's with +, B's
// with -), for the six vertices' screen x, y and z_ndc; then the viewport
// and w-divide adjoints to clip. Contributions are added in pair order:
// bit-identical for any thread count.
template <class T>
void visibility_antialias_backward(const VisibilityAntialiasParams<T>& p, const std::vector<VisibilityPair>& pairs,
                                   const T* grad_out, const AntialiasGrads<T>& grads);

}  // namespace gr::raster
