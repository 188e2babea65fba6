// Four-lane vectors (internal) for per-vertex rows of three channels padded
// to four: one vector operation where the scalar code had three. Lane c does
// exactly channel c's scalar operations (IEEE, no contraction: the build's
// -ffp-contract=off), so results keep the scalar code's bits; lane 3 is padding.
#pragma once

namespace gr::detail {

template <class T>
struct LaneType;
template <>
struct LaneType<float> {
  typedef float type __attribute__((vector_size(16)));
};
template <>
struct LaneType<double> {
  typedef double type __attribute__((vector_size(32)));
};
template <class T>
using Lanes4 = typename LaneType<T>::type;

}  // namespace gr::detail
