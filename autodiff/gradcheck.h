// gradcheck: compares the tape's gradients with central finite differences in
// float64, like torch.autograd.gradcheck.
//
// For a function f(inputs) -> y, it draws fixed-seed random weights v of y's
// shape and checks dL/dx for L = sum(v * y): the analytic side is one
// backward(y, v); the numeric side is (L(x + eps e_k) - L(x - eps e_k)) / 2 eps
// for every element k of every input that requires grad. A wrong Jacobian
// entry changes this projection for almost every v, and several projections
// (options.projections) make a miss vanishingly unlikely.
//
// An element passes when |analytic - numeric| <= atol + rtol * |numeric|.
// The reported relative error is |a - n| / max(|a|, |n|), taken over elements
// with max(|a|, |n|) >= options.min_magnitude (smaller ones are judged by their
// absolute error only, since rounding dominates there).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "autodiff/tensor.h"

namespace gr {

struct GradcheckOptions {
  double eps = 1e-6;
  double atol = 1e-7;
  double rtol = 1e-6;
  double min_magnitude = 1e-4;
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
