// Sparse row sums over per-vertex neighbour lists (internal): the one loop
// behind the mesh Laplacians and the large-steps product, in parallel over
// rows and deterministic (each row summed from 0 in its list's order by one
// thread, so results do not depend on the thread count).
#pragma once

#include <algorithm>
#include <cstdint>
#include <type_traits>

#include "autodiff/base/parallel.h"
#include "ops/mesh/topology.h"

namespace gr::detail {

// Rows per parallel chunk: each row reads about (mean degree + 1) C values,
// and a chunk reads 4 elementwise grains' worth. Measured on 2 threads: a
// 2562-vertex product (13 us) runs faster inline than split (launch and
// wake-up cost more than half of it); 10242 vertices split 54 -> 38 us.
inline std::int64_t row_sum_grain(const VertexRows& r, std::int64_t channels) {
  const std::int64_t rows = std::max<std::int64_t>(1, r.rows());
  const std::int64_t reads = (std::int64_t(r.column.size()) / rows + 1) * std::max<std::int64_t>(1, channels);
  return std::max<std::int64_t>(1, 4 * kElementwiseGrain / reads);
}

// For every row i (in parallel over rows) and channel c < C:
//   emit(i, c, sum over entries e of row i of term(e, column[e], c)),
// each sum from 0 in the row's entry order. C = 1..4 get accumulators of
// fixed length (one pass over the row), other C one pass per channel.
template <class T, class Term, class Emit>
void row_sums(const VertexRows& r, std::int64_t channels, Term term, Emit emit) {
  const std::int64_t* start = r.start.data();
  const std::int32_t* col = r.column.data();
  auto rows = [&](auto fixed, std::int64_t lo, std::int64_t hi) {
    constexpr int K = decltype(fixed)::value;
    for (std::int64_t i = lo; i < hi; ++i) {
      T s[K] = {};
      for (std::int64_t e = start[i]; e < start[i + 1]; ++e)
        for (int c = 0; c < K; ++c) s[c] += term(e, col[e], c);
      for (int c = 0; c < K; ++c) emit(i, c, s[c]);
    }
  };
  parallel_for(0, r.rows(), row_sum_grain(r, channels), [&](std::int64_t lo, std::int64_t hi) {
    switch (channels) {
      case 1: return rows(std::integral_constant<int, 1>(), lo, hi);
      case 2: return rows(std::integral_constant<int, 2>(), lo, hi);
      case 3: return rows(std::integral_constant<int, 3>(), lo, hi);
      case 4: return rows(std::integral_constant<int, 4>(), lo, hi);
      default:
        for (std::int64_t i = lo; i < hi; ++i)
          for (std::int64_t c = 0; c < channels; ++c) {
            T s = 0;
            for (std::int64_t e = start[i]; e < start[i + 1]; ++e) s += term(e, col[e], std::int64_t(c));
            emit(i, c, s);
          }
    }
  });
}

}  // namespace gr::detail
