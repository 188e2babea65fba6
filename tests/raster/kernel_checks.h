// Helpers for the raster/ kernel tests, which work on plain arrays (the
// tensor-level gradcheck is for ops): random vectors, finiteness, and a
// central-difference check of a hand-written gradient.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <vector>

namespace gr::testing {

// Clip positions (4 per vertex) of every magnitude T holds: random signs and
// exponents, zeros, ones, denormals and the largest finite values, so that
// near-plane crossings round anywhere (even to w = 0), and random triangles
// over them (3 indices each).
template <class T>
std::vector<T> extreme_clip(int vertices, unsigned seed) {
  std::mt19937 rng(seed);
  const int max_exp = std::numeric_limits<T>::max_exponent10 - 1;
  std::uniform_real_distribution<double> exponent(-max_exp, max_exp);
  std::uniform_int_distribution<int> pick(0, 7);
  const T specials[] = {T(0), T(1), std::numeric_limits<T>::denorm_min(), std::numeric_limits<T>::max()};
  std::vector<T> clip;
  for (int i = 0; i < 4 * vertices; ++i) {
    const int k = pick(rng);
    const T magnitude = k < 4 ? specials[k] : static_cast<T>(std::pow(10.0, exponent(rng)));
    clip.push_back(pick(rng) % 2 ? -magnitude : magnitude);
  }
  return clip;
}

inline std::vector<std::int32_t> random_triangles(int triangles, int vertices, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::int32_t> vertex(0, vertices - 1);
  std::vector<std::int32_t> tris;
  for (int t = 0; t < 3 * triangles; ++t) tris.push_back(vertex(rng));
  return tris;
}

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
