// Vector ops on the last axis (3-vectors for graphics, any length for dot,
// length and normalize). Results keep the last axis with extent 1 where they
// are scalar per vector (dot, length), so they broadcast against vectors:
//   n_dot_l = dot(n, l);            // [..., 1]
//   diffuse = albedo * maximum(n_dot_l, 0.0);
#pragma once

#include "autodiff/base/tensor.h"

namespace gr {

// Default epsilon of normalize and length: below this length a vector is
// treated as having length eps (see normalize).
constexpr double kNormalizeEps = 1e-12;

// sum_i a_i b_i over the last axis, broadcasting the leading axes; [..., 1].
// The last axes must be equal. dL/da = g b, dL/db = g a (summed over broadcast axes).
Tensor dot(const Tensor& a, const Tensor& b);
// a x b of 3-vectors on the last axis (extent 3 required), broadcasting.
// dL/da = b x g, dL/db = g x a (summed over broadcast axes).
Tensor cross(const Tensor& a, const Tensor& b);
// |v| = sqrt(sum v_i^2), [..., 1]. dL/dv = g v / max(|v|, eps): 0 at v == 0.
Tensor length(const Tensor& v, double eps = kNormalizeEps);
// v / max(|v|, eps). For |v| > eps: dL/dv = (g - n (n.g)) / |v|; for |v| <= eps
// the op is v / eps, so dL/dv = g / eps (finite at v == 0; output 0 there).
Tensor normalize(const Tensor& v, double eps = kNormalizeEps);
// Mirror of incident direction i about normal n: i - 2 (n.i) n (n unit length).
// Composite of dot, mul and sub: dL/di = g - 2 n (n.g),
// dL/dn = -2 ((n.g) i + (n.i) g).
Tensor reflect(const Tensor& i, const Tensor& n);

}  // namespace gr
