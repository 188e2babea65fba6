// The elementwise op table (ops/tensor/elementwise_table.h): for every entry, the
// eager op and its replay by the fused row interpreter (map_rows) give the
// same values and row gradients bit for bit, in float32 and float64, for
// every operand form the interpreter reads; and the replay's gradients pass a
// float64 gradcheck. The cases walk the table, so a new entry is checked here
// without a new test.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <string>

#include "ops/tensor/elementwise_table.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;
using detail::OpId;
using detail::OpKind;
using Inputs = std::vector<Tensor>;

namespace {

constexpr std::int64_t kRows = 1301, kBlock = 500;  // a partial last block

// Uniform in [lo, hi), needing a gradient.
Tensor uniform_leaf(const Shape& shape, double lo, double hi, std::uint64_t seed, DType dtype) {
  Tensor t = Tensor::uniform(shape, lo, hi, seed, dtype);
  t.set_requires_grad();
  return t;
}

// t's values changed by edit(values), needing a gradient.
template <class F>
Tensor edited(const Tensor& t, F edit) {
  std::vector<double> v = t.to_vector();
  edit(v);
  Tensor out = Tensor::from_values(v, t.shape(), t.dtype());
  out.set_requires_grad();
  return out;
}

std::vector<OpId> table_entries() {
  std::vector<OpId> ids;
  for (int i = 0; i < detail::UnaryOps::size; ++i) ids.push_back({OpKind::Unary, i});
  for (int i = 0; i < detail::BinaryOps::size; ++i) ids.push_back({OpKind::Binary, i});
  return ids;
}

// rows: x [N, 3], z [N, 3] (ties with x in its first rows), c [N, 1]; shared:
// s [3], k []; all in [lo, hi) and needing gradients.
struct Case {
  Inputs rows, shared;
};

Case make_case(std::int64_t n, DType dtype, double lo, double hi, std::uint64_t seed) {
  const Tensor x = uniform_leaf({n, 3}, lo, hi, seed, dtype);
  const Tensor z = edited(uniform_leaf({n, 3}, lo, hi, seed + 1, dtype), [&](std::vector<double>& v) {
    const std::vector<double> xv = x.to_vector();
    std::copy(xv.begin(), xv.begin() + 60, v.begin());  // ties
  });
  return {{x, z, uniform_leaf({n, 1}, lo, hi, seed + 2, dtype)},
          {uniform_leaf({3}, lo, hi, seed + 3, dtype), uniform_leaf({}, lo, hi, seed + 4, dtype)}};
}

// The entry applied to every operand form the interpreter reads: rows of the
// same shape, a column either side, a shared vector and a shared scalar either
// side, a constant f creates, the result of another step, and a value used
// more than once.
RowFunction graph_of(OpId op) {
  if (op.kind == OpKind::Unary)
    return [op](const Inputs& r, const Inputs&) {
      const Tensor y = detail::eager_op(op, r[0]);
      return detail::eager_op(op, y * 0.25 + 1.5) + y + detail::eager_op(op, r[2]) * r[1];
    };
  return [op](const Inputs& r, const Inputs& s) {
    auto f = [op](const Tensor& a, const Tensor& b) { return detail::eager_op(op, a, b); };
    const Tensor constant = Tensor::from_values({0.5, 0.75, 1.25}, {3}, r[0].dtype());
    const Tensor y = f(r[0], r[1]);
    return f(y, r[2]) - f(r[2], r[1]) + f(s[0], r[0]) * f(r[1], s[1]) + f(s[1], r[0]) * f(r[0], constant) +
           f(r[1], r[1]);
  };
}

// Same shape, dtype and bits, except that a NaN matches any NaN: which NaN an
// operation on two NaNs returns (its sign) depends on the order in which the
// compiler puts the operands of a commutative + or *, which the source does
// not fix (IEEE 754 leaves it open). Numbers, infinities and zeros' signs must match.
bool same_bits_or_nan(const Tensor& a, const Tensor& b) {
  if (a.shape() != b.shape() || a.dtype() != b.dtype()) return false;
  const std::vector<double> x = a.to_vector(), y = b.to_vector();
  for (std::size_t e = 0; e < x.size(); ++e)
    if (!(std::isnan(x[e]) && std::isnan(y[e])) && std::memcmp(&x[e], &y[e], sizeof(double)) != 0) return false;
  return true;
}

// f's output, then the rows' gradients of sum(out * w) for a fixed random w.
std::vector<Tensor> output_and_row_grads(const Case& c, const std::function<Tensor()>& f) {
  for (Tensor t : c.rows) t.zero_grad();
  for (Tensor t : c.shared) t.zero_grad();
  const Tensor out = f();
  backward(sum(out * Tensor::uniform(out.shape(), -1, 1, 9, out.dtype())));
  std::vector<Tensor> result{out};
  for (const Tensor& t : c.rows) result.push_back(t.grad());
  return result;
}

}  // namespace

TEST_CASE("every elementwise table entry's map_rows replay gives its eager op's values and gradients bit for bit",
          "[ops][elementwise][map_rows][fused]") {
  // Positive values (every entry's domain: no NaN), and values of both signs
  // with zeros and ties (the kinks of abs, min, max; infinities and NaN where
  // an entry's domain ends).
  struct Domain {
    const char* name;
    double lo, hi;
    bool zeros;
  };
  for (const Domain& d : {Domain{"positive", 0.25, 2.0, false}, Domain{"signed", -2.0, 2.0, true}})
    for (DType dtype : {DType::Float32, DType::Float64}) {
      Case c = make_case(kRows, dtype, d.lo, d.hi, 1);
      if (d.zeros)  // in the rows of vectors
        for (std::size_t i : {0, 1})
          c.rows[i] = edited(c.rows[i], [](std::vector<double>& v) { std::fill(v.begin(), v.begin() + 12, 0.0); });
      for (const OpId op : table_entries()) {
        const RowFunction f = graph_of(op);
        INFO(detail::op_name(op) << ", " << d.name << ", " << dtype_name(dtype));
        REQUIRE(map_rows_fuses(f, c.rows, c.shared, MapRowsOptions{kBlock}));
        const auto eager = output_and_row_grads(c, [&] { return f(c.rows, c.shared); });
        const auto fused = output_and_row_grads(c, [&] { return map_rows(f, c.rows, c.shared, MapRowsOptions{kBlock}); });
        for (std::size_t i = 0; i < eager.size(); ++i) {
          const std::string what = i == 0 ? "output" : "rows[" + std::to_string(i - 1) + "]'s gradient";
          INFO(what);
          // Strictly the same bits where no NaN arises.
          CHECK((d.zeros ? same_bits_or_nan(fused[i], eager[i]) : same_bits(fused[i], eager[i])));
        }
      }
    }
}

TEST_CASE("every elementwise table entry's replay passes a float64 gradcheck", "[ops][elementwise][map_rows][gradcheck]") {
  // Positive values (inside every entry's domain, away from abs's kink), each
  // input on its own offset of a 0.01 grid, so no two values the graph
  // compares (min, max) come within the gradcheck's steps of a tie.
  const Case c = make_case(120, DType::Float64, 0.25, 2.0, 31);
  Inputs in = c.rows;
  in.insert(in.end(), c.shared.begin(), c.shared.end());
  const double offsets[] = {0.0031, 0.0067, 0.0049, 0.0083, 0.0015};
  for (std::size_t i = 0; i < in.size(); ++i)
    in[i] = edited(in[i], [&](std::vector<double>& v) {
      for (double& x : v) x = 0.25 + 0.01 * std::floor((x - 0.25) / 0.01) + offsets[i];
    });
  for (const OpId op : table_entries()) {
    const RowFunction f = graph_of(op);
    REQUIRE(map_rows_fuses(f, {in[0], in[1], in[2]}, {in[3], in[4]}, MapRowsOptions{100}));
    require_gradcheck(std::string("replayed ") + detail::op_name(op),
                      [&](const Inputs& x) {
                        return map_rows(f, {x[0], x[1], x[2]}, {x[3], x[4]}, MapRowsOptions{100});
                      },
                      in);
  }
}

TEST_CASE("the table's eager ops are the public functions", "[ops][elementwise]") {
  const Tensor a = Tensor::from_values({0.5, 1.5, -2.0}, {3}), b = Tensor::from_values({2.0, 1.5, 0.25}, {3});
  CHECK(same_bits(detail::eager_op(detail::op_id<detail::SubOp>(), a, b), a - b));
  CHECK(same_bits(detail::eager_op(detail::op_id<detail::MaximumOp>(), a, b), maximum(a, b)));
  CHECK(same_bits(detail::eager_op(detail::op_id<detail::ExpOp>(), a), exp(a)));
  CHECK(std::string(detail::op_name(detail::op_id<detail::PowOp>())) == "pow");
  CHECK_THROWS_AS(detail::eager_op(OpId{OpKind::Dot}, a, b), ValueError);
  CHECK_THROWS_AS(detail::eager_op(OpId{OpKind::Binary, detail::BinaryOps::size}, a, b), ValueError);
}
