// Per-element formulas shared by the eager ops (elementwise.cpp, vector.cpp)
// and the fused row interpreter (fused_rows.cpp), so both round the same way:
// one definition, two evaluators, the same bits.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace gr::detail {

// The gradient of the selected operand of min/max: g where `selected`, g / 2 at
// a tie, else +0. Chosen with bit masks, not branches: on random signs a
// branch mispredicts half the time (the compiler turns ternaries back into
// branches here), and the masks vectorize.
template <class T>
T selected_gradient(T g, bool selected, bool tie) {
  using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  const T half = g * T(0.5);  // = g / 2 exactly
  Bits g_bits, half_bits;
  std::memcpy(&g_bits, &g, sizeof g);
  std::memcpy(&half_bits, &half, sizeof half);
  const Bits bits = (g_bits & (Bits(0) - Bits(selected))) | (half_bits & (Bits(0) - Bits(tie)));
  T out;
  std::memcpy(&out, &bits, sizeof out);
  return out;
}

// x^n for an integer n >= 0 by repeated squaring, one bit of n at a time over a
// block of elements so that each step is a plain vectorizable loop.
template <class T>
void integer_power(const T* x, T* out, std::int64_t count, long long n) {
  constexpr std::int64_t kBlock = 256;
  T base[kBlock];
  for (std::int64_t i0 = 0; i0 < count; i0 += kBlock) {
    const std::int64_t m = count - i0 < kBlock ? count - i0 : kBlock;
    for (std::int64_t i = 0; i < m; ++i) { out[i0 + i] = T(1); base[i] = x[i0 + i]; }
    for (long long e = n; e > 0; e >>= 1) {
      if (e & 1)
        for (std::int64_t i = 0; i < m; ++i) out[i0 + i] *= base[i];
      if (e > 1)
        for (std::int64_t i = 0; i < m; ++i) base[i] *= base[i];
    }
  }
}

// out[i] = x[i]^p for i in [lo, hi): repeated squaring for integer |p| <= 64,
// std::pow otherwise.
template <class T>
void power_range(const T* x, T* out, std::int64_t lo, std::int64_t hi, double p) {
  if (p == std::floor(p) && std::fabs(p) <= 64) {
    integer_power(x + lo, out + lo, hi - lo, static_cast<long long>(std::fabs(p)));
    if (p < 0)
      for (std::int64_t i = lo; i < hi; ++i) out[i] = T(1) / out[i];
  } else {
    for (std::int64_t i = lo; i < hi; ++i) out[i] = T(std::pow(x[i], T(p)));
  }
}

// dL/dx of x^p into d[lo, hi): g p x^(p-1), 0 where x == 0 and p < 1 (the
// derivative diverges there). x^(p-1) is computed into d first, while the
// range is in cache; for p = 2 it is x itself (the same products, one pass).
template <class T>
void power_adjoint_range(const T* g, const T* x, T* d, std::int64_t lo, std::int64_t hi, double p) {
  const T pt = T(p);
  if (p == 2) {
    for (std::int64_t i = lo; i < hi; ++i) d[i] = g[i] * pt * x[i];
    return;
  }
  power_range(x, d, lo, hi, p - 1);
  if (p < 1)
    for (std::int64_t i = lo; i < hi; ++i) d[i] = x[i] == T(0) ? T(0) : g[i] * pt * d[i];
  else
    for (std::int64_t i = lo; i < hi; ++i) d[i] = g[i] * pt * d[i];
}

// One element of normalize's forward, x / d with d = max(|v|, eps) in double.
// float64 divides (exact results such as (3, 4) / 5 = (0.6, 0.8) stay exact).
// float32 multiplies by the double 1 / d, which is within 2 double ulps of
// x / d, so rounding to float gives x / d's float except when the quotient lies
// within those 2 ulps of a float rounding boundary (a chance of order 2^-28 per
// element; none among the 300,000 values tests/ops/test_vector.cpp checks);
// three double divisions per row were most of the op's time.
template <class T>
T normalized(double x, double d, double inv_d) {
  if constexpr (std::is_same_v<T, float>)
    return T(x * inv_d);
  else
    return T(x / d);
}

}  // namespace gr::detail
