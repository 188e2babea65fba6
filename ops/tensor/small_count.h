// f(n) with a small count n (1..4: a mesh row's channels, a row's length) as
// a compile-time constant, so that f's loops over it unroll; else f(n) as is.
// Internal to the ops. (row_sums, ops/mesh/row_sums.h, keeps its terms'
// count at run time: unrolled, 4 smoothing passes measured 881 -> 942 K
// instructions.)
#pragma once

#include <cstdint>
#include <type_traits>

namespace gr::detail {

template <class F>
void with_small_count(std::int64_t n, F f) {
  switch (n) {
    case 1: return f(std::integral_constant<std::int64_t, 1>());
    case 2: return f(std::integral_constant<std::int64_t, 2>());
    case 3: return f(std::integral_constant<std::int64_t, 3>());
    case 4: return f(std::integral_constant<std::int64_t, 4>());
    default: return f(n);
  }
}

}  // namespace gr::detail
