// Deterministic gradient sums (docs/gpu.md, "Sums without float atomics"):
// each contribution x is added as the integer round(x 2^S) with a 64-bit
// atomic add, which is associative, so the sum does not depend on the order
// in which threads arrive. S is chosen per call from the largest magnitude M
// of any contribution (a first pass takes it with an atomic max on its bits)
// and the number of pixels P, each element getting at most one contribution
// per pixel: |sum| <= P (M 2^S + 1/2) < 2^63 with S = 62 - e(M) - e(P)
// (e: the exponent with x < 2^e). Resolution: 2^-S = 2^(e(M) + e(P) - 62),
// about M P 2^-61, relative to the largest contribution.
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_KHR_shader_subgroup_arithmetic : require

// Largest magnitudes of the contributions, one per summed tensor (the bits
// of a non-negative double order as unsigned integers).
layout(std430, binding = 8) buffer MaxBuf { uint64_t largest[]; };

// Each invocation keeps the largest of its own contributions per tensor;
// publish_magnitudes takes the largest of its subgroup's and one invocation
// of the subgroup publishes it, with an atomic only where it exceeds what the
// slot already holds. An atomic max per contribution on one address
// serialized millions of atomics (the interpolate adjoint took 3.7 ms on an
// H200); one per subgroup is at most pixels / 32 there (8 on lavapipe).
uint64_t own_largest[2] = uint64_t[2](uint64_t(0), uint64_t(0));

void note_magnitude(int tensor, double x) {
  uvec2 b = unpackDouble2x32(abs(x));
  uint64_t bits = (uint64_t(b.y) << 32) | uint64_t(b.x);
  if ((b.y & 0x7ff00000u) != 0x7ff00000u && bits > own_largest[tensor]) own_largest[tensor] = bits;
}

// Called by every invocation (uniform control flow: subgroup operations).
// The subgroup's largest from 32-bit maxima: the high words', then the low
// words' among the invocations holding that high word.
void publish_magnitudes() {
  for (int t = 0; t < 2; ++t) {
    uint hi = uint(own_largest[t] >> 32), lo = uint(own_largest[t] & 0xffffffffu);
    uint top_hi = subgroupMax(hi);
    uint top_lo = subgroupMax(hi == top_hi ? lo : 0u);
    uint64_t top = (uint64_t(top_hi) << 32) | uint64_t(top_lo);
    if (subgroupElect() && top > largest[t]) atomicMax(largest[t], top);
  }
}

// S for tensor `tensor` with at most `count` contributions per element.
int fixed_point_shift(int tensor, int count) {
  uint64_t bits = largest[tensor];
  double m = packDouble2x32(uvec2(uint(bits & 0xffffffffu), uint(bits >> 32)));
  if (m == 0.0) return 0;
  int em, ec;
  frexp(m, em);
  frexp(double(max(count, 1)), ec);
  return clamp(62 - em - ec, -1000, 1000);
}

// round(x 2^S); both scalings by powers of two are exact.
int64_t to_fixed(double x, int shift) { return int64_t(roundEven(ldexp(x, shift))); }
double from_fixed(int64_t v, int shift) { return ldexp(double(v), -shift); }
