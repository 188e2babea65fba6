// Shared helpers for the test suite.
#pragma once

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "autodiff/gradcheck.h"

namespace gr::testing {

// Runs gradcheck on f and requires it to pass. The report goes to the Catch
// log; with GRADRASTER_GRADCHECK_LOG=path set, a line "name max_rel max_abs" is
// appended to that file so a run can summarize the worst errors over all ops.
inline GradcheckResult require_gradcheck(const std::string& name, const GradcheckFn& f,
                                         const std::vector<Tensor>& inputs,
                                         const GradcheckOptions& options = {}) {
  GradcheckResult r = gradcheck(f, inputs, options);
  INFO(name << ": " << r.report());
  if (const char* log = std::getenv("GRADRASTER_GRADCHECK_LOG")) {
    std::ofstream out(log, std::ios::app);
    out << name << ' ' << r.max_rel_error << ' ' << r.max_abs_error << '\n';
  }
  REQUIRE(r.passed);
  return r;
}

// Double-precision random tensor requiring grad (a gradcheck input).
inline Tensor random_input(const Shape& shape, double lo, double hi, std::uint64_t seed) {
  Tensor t = Tensor::uniform(shape, lo, hi, seed, DType::Float64);
  t.set_requires_grad();
  return t;
}

// True if no element is NaN or Inf.
inline bool all_finite(const Tensor& t) {
  for (double x : t.to_vector())
    if (!(x - x == 0)) return false;
  return true;
}

// The same doubles bit for bit: +0 and -0 differ, a NaN equals a NaN of the same payload.
inline bool same_bits(const std::vector<double>& x, const std::vector<double>& y) {
  return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0);
}

// Same shape, dtype and bits (to_vector is exact for float32 and float64).
inline bool same_bits(const Tensor& a, const Tensor& b) {
  return a.shape() == b.shape() && a.dtype() == b.dtype() && same_bits(a.to_vector(), b.to_vector());
}

// max_i |a_i - b_i| / max_i |b_i|: how far a is from b, relative to b's size.
inline double max_relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0, scale = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    worst = std::max(worst, std::abs(a[i] - b[i]));
    scale = std::max(scale, std::abs(b[i]));
  }
  return worst / scale;
}

// Column j of a row-major [rows, k] array summed over its rows the way the
// library sums a broadcast operand's gradient (ops/tensor/broadcast.h): blocks of
// 4096 rows, each summed in double from 0, block totals added in order.
inline double blocked_column_sum(const std::vector<double>& v, std::int64_t rows, std::int64_t k, std::int64_t j) {
  double total = 0;
  for (std::int64_t b = 0; b < rows; b += 4096) {
    double block = 0;
    for (std::int64_t r = b; r < std::min(rows, b + 4096); ++r) block += v[r * k + j];
    total += block;
  }
  return total;
}

}  // namespace gr::testing
