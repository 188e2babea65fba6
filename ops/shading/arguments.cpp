// Argument checks of the shading functions (see arguments.h).
#include "ops/shading/arguments.h"

#include <algorithm>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "ops/check.h"

namespace gr::shading::detail {
namespace {

std::string arg(const char* op, const char* name) { return std::string(op) + ": argument '" + name + "' "; }

// The NumPy broadcast of `a` and `b`, or false if they do not broadcast.
bool broadcast(const std::vector<std::int64_t>& a, const std::vector<std::int64_t>& b,
               std::vector<std::int64_t>& out) {
  const std::size_t rank = std::max(a.size(), b.size());
  out.assign(rank, 1);
  for (std::size_t i = 0; i < rank; ++i) {
    const std::int64_t x = i < a.size() ? a[a.size() - 1 - i] : 1;
    const std::int64_t y = i < b.size() ? b[b.size() - 1 - i] : 1;
    if (x != y && x != 1 && y != 1) return false;
    out[rank - 1 - i] = x == 1 ? y : x;
  }
  return true;
}

}  // namespace

void check_vectors(const Tensor& t, std::int64_t n, const char* op, const char* name) {
  gr::detail::check_float(t, op, name);
  if (t.rank() < 1 || t.size(-1) != n)
    throw ShapeError(arg(op, name) + "must have shape [..., " + std::to_string(n) + "], got " + t.describe());
}

void check_scalars(const Tensor& t, const char* op, const char* name) {
  gr::detail::check_float(t, op, name);
  if (t.rank() >= 1 && t.size(-1) != 1)
    throw ShapeError(arg(op, name) + "must be one value per element, shape [..., 1] or a scalar, got " +
                     t.describe());
}

void check_together(const char* op, std::initializer_list<Argument> args) {
  const Argument& first = *args.begin();
  gr::detail::check_float(first.tensor, op, first.name);
  std::vector<std::int64_t> shape = first.tensor.shape().dims(), next;
  std::string before = first.name;
  for (const Argument& a : args) {
    if (&a == &first) continue;
    gr::detail::check_float(a.tensor, op, a.name);
    gr::detail::check_same_dtype(a.tensor, first.tensor, op, a.name, first.name);
    if (!broadcast(shape, a.tensor.shape().dims(), next) || next.size() > static_cast<std::size_t>(Shape::kMaxRank))
      throw ShapeError(arg(op, a.name) + a.tensor.describe() + " does not broadcast against the shape " +
                       Shape(shape).str() + " of " + before);
    shape = next;
    before += std::string(", ") + a.name;
  }
}

}  // namespace gr::shading::detail
