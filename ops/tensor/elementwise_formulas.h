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

// x^n for an integer n >= 0 by repeated squaring: per element r = 1, b = x,
// then for each bit of n from the lowest, r *= b if it is set and b *= b if a
// higher bit follows. Elements go kRegisters vectors at a time, r and b held
// in registers through all the bits (independent chains, so the multiplier's
// latency overlaps), with the same products in the same order as one element
// at a time; n = 2 is x * x (r = 1 * x^2).
template <class T>
void integer_power(const T* x, T* out, std::int64_t count, long long n) {
  if (n == 2) {
    for (std::int64_t i = 0; i < count; ++i) out[i] = x[i] * x[i];
    return;
  }
  typedef T V __attribute__((vector_size(32)));
  constexpr int kWidth = int(sizeof(V) / sizeof(T)), kRegisters = 8, kBlock = kWidth * kRegisters;
  std::int64_t i0 = 0;
  for (; i0 + kBlock <= count; i0 += kBlock) {
    V b[kRegisters], r[kRegisters];
    for (int k = 0; k < kRegisters; ++k) {
      std::memcpy(&b[k], x + i0 + k * kWidth, sizeof(V));
      r[k] = V{} + T(1);
    }
    for (long long e = n; e > 0; e >>= 1) {
      if (e & 1)
        for (int k = 0; k < kRegisters; ++k) r[k] *= b[k];
      if (e > 1)
        for (int k = 0; k < kRegisters; ++k) b[k] *= b[k];
    }
    for (int k = 0; k < kRegisters; ++k) std::memcpy(out + i0 + k * kWidth, &r[k], sizeof(V));
  }
  for (; i0 < count; ++i0) {
    T r = T(1), b = x[i0];
    for (long long e = n; e > 0; e >>= 1) {
      if (e & 1) r *= b;
      if (e > 1) b *= b;
    }
    out[i0] = r;
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
// element; none among the 300,000 values tests/ops/tensor/test_vector.cpp checks);
// three double divisions per row were most of the op's time.
template <class T>
T normalized(double x, double d, double inv_d) {
  if constexpr (std::is_same_v<T, float>)
    return T(x * inv_d);
  else
    return T(x / d);
}

}  // namespace gr::detail
