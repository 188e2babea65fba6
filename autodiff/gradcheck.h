// gradcheck: compares the tape's gradients with central finite differences in
// float64, like torch.autograd.gradcheck.
//
// For a function f(inputs) -> y, it draws fixed-seed random weights v of y's
// shape and checks dL/dx for L = sum(v * y): the analytic side is one
// backward(y, v); the numeric side is the fourth-order central difference
//   (8 [L(x + h e_k) - L(x - h e_k)] - [L(x + 2h e_k) - L(x - 2h e_k)]) / 12 h,
// h = eps, for every element k of every input that requires grad. Its
// truncation error is O(h^4), so the default step can be large enough to keep
// rounding error (~1e-16 |L| / h) small; choose eps so that x +- 2 eps stays on
// the same smooth piece of f (e.g. does not move a triangle edge across a pixel
// centre). A wrong Jacobian
// entry changes this projection for almost every v, and several projections
// (options.projections) make a miss vanishingly unlikely.
//
// An element passes when |analytic - numeric| <= atol + rtol * |numeric|.
// The reported relative error of an element is
//   |a - n| / max(|a|, |n|, floor),  floor = max(min_magnitude, relative_floor * S),
// with S the largest |numeric| of that input: elements far below the input's
// gradient scale, where the finite-difference reference is mostly rounding
// noise (about 1e-16 |L| / eps), are measured against the floor instead.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

struct GradcheckOptions {
  double eps = 1e-4;
  double atol = 1e-7;
  double rtol = 1e-6;
  double min_magnitude = 1e-12;
  double relative_floor = 1e-3;
  int projections = 2;
  std::uint64_t seed = 12345;
};

struct GradcheckResult {
  bool passed = true;
  double max_abs_error = 0;
  double max_rel_error = 0;
  // The element that is furthest outside tolerance (or, if all pass, the one
  // with the largest absolute error).
  int worst_input = -1;
  std::int64_t worst_index = -1;
  double worst_analytic = 0;
  double worst_numeric = 0;
  std::int64_t elements_checked = 0;
  std::string report() const;
};

using GradcheckFn = std::function<Tensor(const std::vector<Tensor>&)>;

// Inputs must be float64; those with requires_grad are checked (at least one
// must). f must be deterministic. The inputs' .grad() is cleared afterwards.
GradcheckResult gradcheck(const GradcheckFn& f, const std::vector<Tensor>& inputs,
                          const GradcheckOptions& options = {});

}  // namespace gr
