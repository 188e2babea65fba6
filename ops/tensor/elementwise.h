// Elementwise ops with NumPy broadcasting, recorded on the gradient tape.
//
// Binary ops broadcast their operands (shapes are aligned at the last axis; an
// extent of 1 stretches). Float32 with float64 computes in float64 (the
// float32 operand's gradient comes back as float32; ops/tensor/promote.h); a double
// scalar operand takes the tensor's dtype. Adjoints of broadcast
// operands are summed back to the operand's shape.
//
// Derivatives at points where the true derivative is infinite or undefined
// are fixed, finite values (so one degenerate element cannot poison a whole
// optimization with NaN/Inf); each is stated at the function.
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

// dL/da = g, dL/db = g
Tensor add(const Tensor& a, const Tensor& b);
// dL/da = g, dL/db = -g
Tensor sub(const Tensor& a, const Tensor& b);
// dL/da = g b, dL/db = g a
Tensor mul(const Tensor& a, const Tensor& b);
// dL/da = g / b, dL/db = -(g a/b) / b  (evaluated in that order so that a
// tiny b does not underflow b^2 to zero)
Tensor div(const Tensor& a, const Tensor& b);
// a^b. dL/da = g b a^(b-1), except 0 where a == 0 and b < 1 (the true
// derivative diverges there); dL/db = g a^b ln(a) for a > 0, and 0 for a <= 0.
Tensor pow(const Tensor& a, const Tensor& b);
// a^p with a constant exponent; dL/da = g p a^(p-1), and 0 at a == 0 when p < 1.
Tensor pow(const Tensor& a, double p);
// Elementwise min/max. At ties the gradient is split evenly (g/2 to each).
Tensor minimum(const Tensor& a, const Tensor& b);
Tensor maximum(const Tensor& a, const Tensor& b);

// dL/da = -g
Tensor neg(const Tensor& a);
// dL/da = g exp(a)
Tensor exp(const Tensor& a);
// dL/da = g / a (IEEE: +-inf at a == 0, the true value)
Tensor log(const Tensor& a);
// dL/da = g / (2 sqrt(a)) for a > 0, and 0 at a == 0 (the true derivative diverges).
Tensor sqrt(const Tensor& a);
// 1/sqrt(a). dL/da = -g / (2 a sqrt(a)) = -g rsqrt(a)^3 / 2
Tensor rsqrt(const Tensor& a);
// dL/da = g cos(a)
Tensor sin(const Tensor& a);
// dL/da = -g sin(a)
Tensor cos(const Tensor& a);
// dL/da = g sign(a), with sign(0) = 0
Tensor abs(const Tensor& a);
// min(max(a, lo), hi). dL/da = g where lo <= a <= hi (bounds inclusive), else 0.
Tensor clamp(const Tensor& a, double lo, double hi);

// Comparison masks: 1 where the relation holds, 0 elsewhere, in the dtype of
// the operands (broadcast). Masks carry no gradient.
Tensor less(const Tensor& a, const Tensor& b);
Tensor less_equal(const Tensor& a, const Tensor& b);
Tensor greater(const Tensor& a, const Tensor& b);
Tensor greater_equal(const Tensor& a, const Tensor& b);
Tensor equal(const Tensor& a, const Tensor& b);
Tensor not_equal(const Tensor& a, const Tensor& b);

// mask != 0 ? a : b, broadcasting all three. dL/da = g [mask], dL/db = g [!mask];
// the mask gets no gradient.
Tensor where(const Tensor& mask, const Tensor& a, const Tensor& b);

// Converts between float32 and float64 (differentiable: the gradient is cast
// back); casting to or from int32 is allowed only for tensors that need no gradient.
// Float to int32 truncates toward zero; NaN, Inf or a value outside the int32 range
// throws ValueError naming the element's index and value.
Tensor cast(const Tensor& a, DType dtype);

// A scalar tensor of a's dtype (for mixing tensors and numbers).
Tensor scalar_like(const Tensor& a, double value);

inline Tensor operator+(const Tensor& a, const Tensor& b) { return add(a, b); }
inline Tensor operator-(const Tensor& a, const Tensor& b) { return sub(a, b); }
inline Tensor operator*(const Tensor& a, const Tensor& b) { return mul(a, b); }
inline Tensor operator/(const Tensor& a, const Tensor& b) { return div(a, b); }
inline Tensor operator-(const Tensor& a) { return neg(a); }
inline Tensor operator+(const Tensor& a, double s) { return add(a, scalar_like(a, s)); }
inline Tensor operator+(double s, const Tensor& a) { return add(scalar_like(a, s), a); }
inline Tensor operator-(const Tensor& a, double s) { return sub(a, scalar_like(a, s)); }
inline Tensor operator-(double s, const Tensor& a) { return sub(scalar_like(a, s), a); }
inline Tensor operator*(const Tensor& a, double s) { return mul(a, scalar_like(a, s)); }
inline Tensor operator*(double s, const Tensor& a) { return mul(scalar_like(a, s), a); }
inline Tensor operator/(const Tensor& a, double s) { return div(a, scalar_like(a, s)); }
inline Tensor operator/(double s, const Tensor& a) { return div(scalar_like(a, s), a); }
inline Tensor minimum(const Tensor& a, double s) { return minimum(a, scalar_like(a, s)); }
inline Tensor maximum(const Tensor& a, double s) { return maximum(a, scalar_like(a, s)); }

}  // namespace gr

// ---- Conveniences: comparisons with a number, comparison operators ----
// (Same masks as above. A double takes the tensor's dtype, as in arithmetic.)
namespace gr {

inline Tensor less(const Tensor& a, double s) { return less(a, scalar_like(a, s)); }
inline Tensor less_equal(const Tensor& a, double s) { return less_equal(a, scalar_like(a, s)); }
inline Tensor greater(const Tensor& a, double s) { return greater(a, scalar_like(a, s)); }
inline Tensor greater_equal(const Tensor& a, double s) { return greater_equal(a, scalar_like(a, s)); }
inline Tensor equal(const Tensor& a, double s) { return equal(a, scalar_like(a, s)); }
inline Tensor not_equal(const Tensor& a, double s) { return not_equal(a, scalar_like(a, s)); }

// Operators compare values elementwise and return masks, like NumPy's: a == b
// is a tensor, not a bool (Tensor::same() asks whether two handles are one tensor).
inline Tensor operator<(const Tensor& a, const Tensor& b) { return less(a, b); }
inline Tensor operator<=(const Tensor& a, const Tensor& b) { return less_equal(a, b); }
inline Tensor operator>(const Tensor& a, const Tensor& b) { return greater(a, b); }
inline Tensor operator>=(const Tensor& a, const Tensor& b) { return greater_equal(a, b); }
inline Tensor operator==(const Tensor& a, const Tensor& b) { return equal(a, b); }
inline Tensor operator!=(const Tensor& a, const Tensor& b) { return not_equal(a, b); }
inline Tensor operator<(const Tensor& a, double s) { return less(a, s); }
inline Tensor operator<=(const Tensor& a, double s) { return less_equal(a, s); }
inline Tensor operator>(const Tensor& a, double s) { return greater(a, s); }
inline Tensor operator>=(const Tensor& a, double s) { return greater_equal(a, s); }
inline Tensor operator==(const Tensor& a, double s) { return equal(a, s); }
inline Tensor operator!=(const Tensor& a, double s) { return not_equal(a, s); }
inline Tensor operator<(double s, const Tensor& a) { return greater(a, s); }
inline Tensor operator<=(double s, const Tensor& a) { return greater_equal(a, s); }
inline Tensor operator>(double s, const Tensor& a) { return less(a, s); }
inline Tensor operator>=(double s, const Tensor& a) { return less_equal(a, s); }
inline Tensor operator==(double s, const Tensor& a) { return equal(a, s); }
inline Tensor operator!=(double s, const Tensor& a) { return not_equal(a, s); }

}  // namespace gr
