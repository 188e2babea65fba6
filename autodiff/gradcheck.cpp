#include "autodiff/gradcheck.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "autodiff/tape.h"

namespace gr {
namespace {

double weighted_sum(const Tensor& y, const std::vector<double>& v) {
  const double* d = y.data<double>();
  double s = 0;
  for (std::size_t i = 0; i < v.size(); ++i) s += v[i] * d[i];
  return s;
}

Tensor evaluate(const GradcheckFn& f, const std::vector<Tensor>& inputs) {
  Tensor y = f(inputs);
  if (!y.defined()) throw ValueError("gradcheck: the function returned an undefined tensor");
  if (y.dtype() != DType::Float64) throw DTypeError("gradcheck: the function must return float64, got " + y.describe());
  return y;
}

}  // namespace

GradcheckResult gradcheck(const GradcheckFn& f, const std::vector<Tensor>& inputs, const GradcheckOptions& o) {
  bool any = false;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (!inputs[i].defined()) continue;
    if (inputs[i].requires_grad()) {
      any = true;
      if (inputs[i].dtype() != DType::Float64)
        throw DTypeError("gradcheck: input " + std::to_string(i) + " is " + inputs[i].describe() + "; checked inputs must be float64");
      if (!inputs[i].is_leaf()) throw TapeError("gradcheck: input " + std::to_string(i) + " must be a leaf tensor");
    }
  }
  if (!any) throw ValueError("gradcheck: no input requires grad, nothing to check");

  GradcheckResult r;
  double worst_score = -1;
  for (int p = 0; p < o.projections; ++p) {
    // Analytic: one backward with upstream weights v.
    for (const Tensor& in : inputs) if (in.defined()) const_cast<Tensor&>(in).zero_grad();
    Tensor y = evaluate(f, inputs);
    if (!y.requires_grad()) throw TapeError("gradcheck: the output does not depend on any input that requires grad");
    Tensor v = Tensor::uniform(y.shape(), -1.0, 1.0, o.seed + 7919 * p, DType::Float64);
    const std::vector<double> weights = v.to_vector();
    backward(y, v);

    NoGradGuard no_grad;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      Tensor x = inputs[i];
      if (!x.defined() || !x.requires_grad()) continue;
      Tensor g = x.grad();
      double* xd = x.data<double>();
      std::vector<double> analytic_values, numeric_values;
      for (std::int64_t k = 0; k < x.numel(); ++k) {
        const double analytic = g.defined() ? g.data<double>()[k] : 0.0;
        const double saved = xd[k];
        auto loss_at = [&](double step) {
          xd[k] = saved + step;
          return weighted_sum(evaluate(f, inputs), weights);
        };
        // Fourth-order central difference: error O(eps^4) instead of O(eps^2),
        // which allows a larger step and so less rounding error.
        const double d1 = loss_at(o.eps) - loss_at(-o.eps);
        const double d2 = loss_at(2 * o.eps) - loss_at(-2 * o.eps);
        xd[k] = saved;
        analytic_values.push_back(analytic);
        numeric_values.push_back((8 * d1 - d2) / (12 * o.eps));
      }
      // The input's gradient scale sets the floor below which an element's
      // error is measured relative to that floor instead of to itself.
      double scale = 0;
      for (double n : numeric_values) scale = std::fmax(scale, std::fabs(n));
      const double floor = std::fmax(o.min_magnitude, o.relative_floor * scale);
      for (std::int64_t k = 0; k < x.numel(); ++k) {
        const double analytic = analytic_values[k], numeric = numeric_values[k];
        const double err = std::fabs(analytic - numeric);
        const double mag = std::fmax(std::fmax(std::fabs(analytic), std::fabs(numeric)), floor);
        const double tol = o.atol + o.rtol * std::fabs(numeric);
        const bool ok = err <= tol;  // false for NaN too
        r.elements_checked++;
        r.passed = r.passed && ok;
        if (!(err <= r.max_abs_error)) r.max_abs_error = err;
        if (!(err / mag <= r.max_rel_error)) r.max_rel_error = err / mag;
        const double score = std::isnan(err) ? INFINITY : err / tol;
        if (score > worst_score) {
          worst_score = score;
          r.worst_input = static_cast<int>(i);
          r.worst_index = k;
          r.worst_analytic = analytic;
          r.worst_numeric = numeric;
        }
      }
    }
  }
  for (const Tensor& in : inputs) if (in.defined()) const_cast<Tensor&>(in).zero_grad();
  return r;
}

std::string GradcheckResult::report() const {
  std::ostringstream s;
  s.precision(6);
  s << (passed ? "gradcheck passed" : "gradcheck FAILED") << ": " << elements_checked
    << " elements, max abs error " << max_abs_error << ", max rel error " << max_rel_error
    << "; worst element: input " << worst_input << " index " << worst_index << " analytic "
    << worst_analytic << " numeric " << worst_numeric;
  return s.str();
}

}  // namespace gr
