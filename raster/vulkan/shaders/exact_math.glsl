// Shared by every shader: the arithmetic that must give the CPU's bits.
// - every double expression is `precise` (no fused multiply-add the CPU does
//   not do: the CPU build uses -ffp-contract=off);
// - division goes through div_rn (correctly rounded whatever the driver's
//   double division gives);
// - finiteness and signed zeros are decided on the bits, not with isinf/isnan
//   (which a driver may assume away).

bool finite_bits(double x) { return (unpackDouble2x32(x).y & 0x7ff00000u) != 0x7ff00000u; }

// a / b rounded to nearest: one Newton step on the reciprocal, then
// Markstein's correction (the quotient is exact to the last bit for normal
// operands; the CPU's IEEE division gives the same).
double div_rn(double a, double b) {
  precise double y = 1.0 / b;
  precise double e = fma(-b, y, 1.0);
  y = fma(e, y, y);
  precise double q = a * y;
  precise double r = fma(-b, q, a);
  precise double res = fma(r, y, q);
  // A zero over a finite non-zero: the zero with the sign IEEE gives, made on
  // the bits (a compiler may fold 0 * x or 0 / x to +0). Other non-finite or
  // zero operands: the plain quotient (inf, nan as IEEE says).
  if (a == 0.0 && b != 0.0 && finite_bits(b))
    return packDouble2x32(uvec2(0u, (unpackDouble2x32(a).y ^ unpackDouble2x32(b).y) & 0x80000000u));
  if (!finite_bits(res) || !finite_bits(y) || a == 0.0) res = a / b;
  return res;
}

// detail::safe_inv: 1 / (x + copysign(1e-30, x)).
double safe_inv(double x) {
  bool negative = (unpackDouble2x32(x).y & 0x80000000u) != 0u;
  precise double d = x + (negative ? -1e-30 : 1e-30);
  return div_rn(1.0, d);
}

// Cross and dot products of homogeneous screen vectors (x, y, w).
dvec3 hcross(dvec3 a, dvec3 b) {
  precise double x = a.y * b.z - a.z * b.y;
  precise double y = a.z * b.x - a.x * b.z;
  precise double w = a.x * b.y - a.y * b.x;
  return dvec3(x, y, w);
}
double hdot(dvec3 a, dvec3 b) {
  precise double d = (a.x * b.x + a.y * b.y) + a.z * b.z;
  return d;
}

// double -> float as the CPU kernels write their results: detail::finite_cast
// (NaN to 0, clamped to float's finite range) and saturate<float> (clamped).
const double kFloatMax = 3.4028234663852886e38;
float finite_float(double x) {
  if (!(x == x)) return 0.0;
  return float(clamp(x, -kFloatMax, kFloatMax));
}
float saturate_float(double x) { return float(x > kFloatMax ? kFloatMax : x < -kFloatMax ? -kFloatMax : x); }
