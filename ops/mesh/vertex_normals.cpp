// Vertex normals: normalize (ops/tensor/vector.h) of the per-vertex sums of
// the faces' cross products. The sums are one recorded op, forward and
// adjoint side by side below (issue 31: as a composite of gathers, cross,
// concat and scatter_add it built four index lists and seven temporaries per
// call, about a tenth of the fit example's per-iteration work).
#include "ops/mesh/vertex_normals.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "autodiff/base/dtype.h"
#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/tape.h"
#include "ops/mesh/lanes.h"
#include "ops/mesh/topology.h"
#include "ops/render/recent_entries.h"
#include "ops/render/tensor_stamp.h"
#include "raster/detail/buckets.h"

namespace gr {
namespace {

// Corner j = k F + f is corner k of face f (the three corner columns one after
// another). corners.item lists each vertex's corners in ascending j: the
// order in which a scatter_add of the columns adds them, kept so that the
// sums are that composite's bits.
struct NormalSumParams {
  std::int64_t faces = 0, vertices = 0;
  const std::int32_t* tris = nullptr;  // [F, 3]
  std::shared_ptr<const raster::detail::Buckets> corners;
};

// The corner lists of a triangle list, column-major corners j = kF + f
// bucketed by vertex.
std::shared_ptr<const raster::detail::Buckets> corner_lists(const Tensor& triangles, std::int64_t vertices) {
  const std::int64_t F = triangles.size(0);
  const std::int32_t* t = triangles.data<std::int32_t>();
  auto corners = std::make_shared<raster::detail::Buckets>();
  guard_allocation("vertex_normals", [&] {
    std::vector<std::int32_t> column_major(static_cast<std::size_t>(3 * F));
    for (int k = 0; k < 3; ++k)
      for (std::int64_t f = 0; f < F; ++f) column_major[k * F + f] = t[3 * f + k];
    raster::detail::bucket_items(3 * F, vertices, [&](std::int64_t j) { return column_major[j]; }, corners.get());
  });
  return corners;
}

// The corner lists of the last few triangle lists: a fit calls vertex_normals
// with the same triangles at every iteration (ops/render/recent_entries.h:
// used only while the triangles are the tensor they were built from,
// unwritten since).
struct KeptCorners {
  detail::TensorStamp stamp;
  std::int64_t vertices;
  std::shared_ptr<const raster::detail::Buckets> corners;
};

std::shared_ptr<const raster::detail::Buckets> kept_corner_lists(const Tensor& triangles, std::int64_t vertices) {
  static detail::RecentEntries<KeptCorners> kept;
  auto same = [&](const KeptCorners& e) { return e.vertices == vertices && e.stamp.matches(triangles); };
  if (std::optional<KeptCorners> e = kept.find(same)) return e->corners;
  return kept.find_or_keep(same, {detail::TensorStamp::of(triangles), vertices, corner_lists(triangles, vertices)})
      .corners;
}

NormalSumParams normal_sum_params(const Tensor& triangles, std::int64_t vertices) {
  NormalSumParams p;
  p.faces = triangles.size(0);
  p.vertices = vertices;
  p.tris = triangles.data<std::int32_t>();
  if (3 * p.faces > std::numeric_limits<std::int32_t>::max())
    throw ValueError("vertex_normals: argument 'triangles' has " + std::to_string(p.faces) +
                     " faces, more than 2^31 / 3 corners can number");
  p.corners = kept_corner_lists(triangles, vertices);
  return p;
}

// Faces per parallel chunk (about 30 flops each) and vertices (about six corners each).
constexpr std::int64_t kFaceGrain = kElementwiseGrain / 8;
constexpr std::int64_t kVertexGrain = kElementwiseGrain / 8;

// s_v = sum over v's corners (ascending j) of n_f = (p1 - p0) x (p2 - p0),
// all in T with cross's expressions (ops/tensor/vector.cpp); 0 for a vertex of
// no face. The face pass writes n_f at each of its corners' j, so the vertex
// pass reads by j directly (four-lane rows: one vector add per corner).
template <class T>
void normal_sums_forward(const NormalSumParams& p, const T* positions, T* out) {
  using Lanes = detail::Lanes4<T>;  // n_f padded to four lanes (ops/mesh/lanes.h)
  const std::int64_t F = p.faces;
  // Scratch from the storage cache (no page faults once warm); every row written.
  Tensor corner_rows = Tensor::empty({3 * F, 4}, dtype_of<T>::value);
  Lanes* const corner = reinterpret_cast<Lanes*>(corner_rows.data<T>());
  const std::int32_t* const tris = p.tris;
  parallel_for(0, F, kFaceGrain, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t f = lo; f < hi; ++f) {
      const T *p0 = positions + 3 * std::int64_t(tris[3 * f]), *p1 = positions + 3 * std::int64_t(tris[3 * f + 1]),
              *p2 = positions + 3 * std::int64_t(tris[3 * f + 2]);
      const T u[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
      const T v[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
      const Lanes n = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0], T(0)};
      corner[f] = corner[F + f] = corner[2 * F + f] = n;
    }
  });
  const std::int64_t* const start = p.corners->start.data();
  const std::int32_t* const item = p.corners->item.data();
  parallel_for(0, p.vertices, kVertexGrain, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t v = lo; v < hi; ++v) {
      Lanes s = {};
      for (std::int64_t e = start[v]; e < start[v + 1]; ++e) s += corner[item[e]];
      for (int d = 0; d < 3; ++d) out[3 * v + d] = s[d];
    }
  });
}

// The adjoint for g = dL/ds [V, 3], into grad [V, 3] (overwritten): face f
// gets G_f = g_0 + g_1 + g_2 (its corners' g); with u = p1 - p0, v = p2 - p0
// and g . (u x v) = u . (v x g) = v . (g x u), dL/dp1 = v x G, dL/dp2 = G x u
// and dL/dp0 = -(both). Each vertex sums its corners' terms in double, in
// ascending j (thread-count independent), rounded once. The face pass writes
// every corner's term at its j, so the vertex pass only adds (issue 31: the
// corner's kind, found per corner in the vertex pass, cost twice the adds);
// terms and sums are four-lane vectors, lane d doing component d's operations.
template <class T>
void normal_sums_backward(const NormalSumParams& p, const T* positions, const T* g, T* grad) {
  using Lanes = detail::Lanes4<double>;  // a corner's term padded to four lanes (ops/mesh/lanes.h)
  const std::int64_t F = p.faces;
  // dL/dp of corner j = kF + f, from the storage cache; every row written.
  Tensor corner_terms = Tensor::empty({3 * F, 4}, DType::Float64);
  Lanes* const term = reinterpret_cast<Lanes*>(corner_terms.data<double>());
  const std::int32_t* const tris = p.tris;
  parallel_for(0, F, kFaceGrain, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t f = lo; f < hi; ++f) {
      const T *g0 = g + 3 * std::int64_t(tris[3 * f]), *g1 = g + 3 * std::int64_t(tris[3 * f + 1]),
              *g2 = g + 3 * std::int64_t(tris[3 * f + 2]);
      const T *p0 = positions + 3 * std::int64_t(tris[3 * f]), *p1 = positions + 3 * std::int64_t(tris[3 * f + 1]),
              *p2 = positions + 3 * std::int64_t(tris[3 * f + 2]);
      double u[3], v[3], G[3];
      for (int d = 0; d < 3; ++d) {
        u[d] = p1[d] - p0[d];  // in T, as the forward
        v[d] = p2[d] - p0[d];
        G[d] = (static_cast<double>(g0[d]) + g1[d]) + g2[d];
      }
      const Lanes d1 = {v[1] * G[2] - v[2] * G[1], v[2] * G[0] - v[0] * G[2], v[0] * G[1] - v[1] * G[0], 0.0};
      const Lanes d2 = {G[1] * u[2] - G[2] * u[1], G[2] * u[0] - G[0] * u[2], G[0] * u[1] - G[1] * u[0], 0.0};
      term[f] = -(d1 + d2);
      term[F + f] = d1;
      term[2 * F + f] = d2;
    }
  });
  const std::int64_t* const start = p.corners->start.data();
  const std::int32_t* const item = p.corners->item.data();
  parallel_for(0, p.vertices, kVertexGrain, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t v = lo; v < hi; ++v) {
      Lanes s = {};
      for (std::int64_t e = start[v]; e < start[v + 1]; ++e) s += term[item[e]];
      for (int d = 0; d < 3; ++d) grad[3 * v + d] = static_cast<T>(s[d]);
    }
  });
}

// The recorded op: [V, 3] sums of the face normals at each vertex.
Tensor normal_sums(const Tensor& positions, const Tensor& triangles) {
  const NormalSumParams p = normal_sum_params(triangles, positions.size(0));
  Tensor out = Tensor::empty(positions.shape(), positions.dtype());
  dispatch_float(positions.dtype(), "vertex_normals", [&](auto tag) {
    using T = decltype(tag);
    normal_sums_forward<T>(p, positions.data<T>(), out.data<T>());
  });
  if (should_record({positions})) {
    // triangles: no gradient, checked for in-place writes (autodiff/tape.h).
    record("vertex_normal_sums", {positions, triangles}, {&out},
           [p, values = positions.detach(), triangles](AdjointContext& ctx) {
             const Tensor& g = ctx.grad_output();
             if (!g.defined() || !ctx.needs_grad(0)) return;
             Tensor grad = Tensor::empty(values.shape(), values.dtype());
             dispatch_float(values.dtype(), "vertex_normals", [&](auto tag) {
               using T = decltype(tag);
               normal_sums_backward<T>(p, values.data<T>(), g.data<T>(), grad.data<T>());
             });
             ctx.accumulate(0, grad);
           });
  }
  return out;
}

}  // namespace

Tensor vertex_normals(const Tensor& positions, const Tensor& triangles, double eps) {
  detail::check_mesh(positions, triangles, "vertex_normals");
  if (!(eps > 0) || !std::isfinite(eps))
    throw ValueError("vertex_normals: argument 'eps' must be positive and finite, got " + std::to_string(eps));
  return normalize(normal_sums(positions, triangles), eps);
}

}  // namespace gr
