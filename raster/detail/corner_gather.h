// The second half of "scatter by gathering" (docs/determinism.md): per-corner
// sums of triangles are added into their vertices by the vertices themselves,
// in parallel over vertices, each vertex over its corners in ascending corner
// order. The callers number their triangles by first pixel (Buckets::nonempty),
// not by index, so that order does not depend on the triangle order either. No
// two tasks write one vertex and the order is fixed, so the result is
// bit-identical for any thread count.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/buckets.h"

namespace gr::raster::detail {

// Corner j = 3 s + k is corner k of triangle tri_of[s] (s in [0, n));
// corners of slots with live[s] == 0 are left out (live null: none is).
// by_vertex: those corners grouped by their vertex (num_vertices keys), in
// ascending corner order.
inline void group_corners(const std::int32_t* tris, const std::int32_t* tri_of, std::int64_t n,
                          const std::uint8_t* live, std::int64_t num_vertices, Buckets* by_vertex) {
  bucket_items(3 * n, num_vertices,
               [&](std::int64_t j) -> std::int64_t {
                 const std::int64_t s = j / 3;
                 return !live || live[s] ? tris[3 * static_cast<std::int64_t>(tri_of[s]) + j % 3] : -1;
               },
               by_vertex);
}

// For every vertex v with a corner in by_vertex (group_corners'), apply(v,
// total) gets total[0, S) = sum over v's corners, ascending j, of their
// partials partial[j * S, j * S + S).
template <class Apply>
void sum_corners(const Buckets& by_vertex, const double* partial, std::int64_t S, const Apply& apply) {
  const Buckets& b = by_vertex;
  const std::int64_t used = static_cast<std::int64_t>(b.nonempty.size());
  parallel_for(0, used, 256, [&](std::int64_t lo, std::int64_t hi) {
    std::vector<double> total(static_cast<std::size_t>(S));
    for (std::int64_t i = lo; i < hi; ++i) {
      const std::int32_t v = b.nonempty[i];
      std::fill(total.begin(), total.end(), 0.0);
      for (std::int64_t e = b.start[v]; e < b.start[v + 1]; ++e) {
        const double* src = partial + static_cast<std::int64_t>(b.item[e]) * S;
        for (std::int64_t c = 0; c < S; ++c) total[c] += src[c];
      }
      apply(static_cast<std::int64_t>(v), total.data());
    }
  });
}

// group_corners then sum_corners; by_vertex is scratch (kept for reuse across calls).
template <class Apply>
void gather_corners(const std::int32_t* tris, const std::int32_t* tri_of, std::int64_t n,
                    const std::uint8_t* live, const double* partial, std::int64_t S, std::int64_t num_vertices,
                    Buckets* by_vertex, const Apply& apply) {
  group_corners(tris, tri_of, n, live, num_vertices, by_vertex);
  sum_corners(*by_vertex, partial, S, apply);
}

// The buffers of an adjoint that scatters by gathering (pixels grouped by
// triangle, then corners by vertex), kept in a ScratchPool across calls so
// that later calls take no page faults.
struct GatherScratch {
  Buckets by_tri, by_vertex;
  std::vector<double> partial;     // per-corner sums
  std::vector<std::uint8_t> live;  // per triangle slot: 0 leaves its corners out
};

}  // namespace gr::raster::detail
