// Helpers for the raster/ kernel tests, which work on plain arrays (the
// tensor-level gradcheck is for ops): random vectors, finiteness, and a
// central-difference check of a hand-written gradient.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

namespace gr::testing {

inline std::vector<double> random_vector(std::size_t n, double lo, double hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(lo, hi);
  std::vector<double> v(n);
  for (double& x : v) x = d(rng);
  return v;
}

inline bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// max_i |numeric_i - analytic_i| / max_i |analytic_i|, where numeric is the
// central difference (f(x + h e_i) - f(x - h e_i)) / 2h of the scalar f.
inline double fd_error(const std::function<double(const std::vector<double>&)>& f, std::vector<double> x,
                       const std::vector<double>& analytic, double h = 1e-6) {
  double err = 0, scale = 1e-30;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double x0 = x[i];
    x[i] = x0 + h;
    const double fp = f(x);
    x[i] = x0 - h;
    const double fm = f(x);
    x[i] = x0;
    err = std::max(err, std::abs((fp - fm) / (2 * h) - analytic[i]));
    scale = std::max(scale, std::abs(analytic[i]));
  }
  return err / scale;
}

}  // namespace gr::testing
