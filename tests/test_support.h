// Shared helpers for the test suite.
#pragma once

#include <catch2/catch.hpp>

#include <cstdlib>
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

}  // namespace gr::testing
