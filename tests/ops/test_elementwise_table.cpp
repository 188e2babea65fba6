// The elementwise op table (ops/elementwise_table.h): for every entry, the
// eager op and its replay by the fused row interpreter (map_rows) give the
// same values and row gradients bit for bit, in float32 and float64, for
// every operand form the interpreter reads; and the replay's gradients pass a
// float64 gradcheck. The cases walk the table, so a new entry is checked here
// without a new test.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <functional>
#include <string>

#include "ops/elementwise_table.h"
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

std::vector<double> values(std::int64_t n, double lo, double hi, std::uint64_t seed) {
  std::vector<double> v(static_cast<std::size_t>(n));
  std::uint64_t s = seed * 6364136223846793005ULL + 1442695040888963407ULL;
  for (double& x : v) {
    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
    x = lo + (hi - lo) * double(s >> 11) / 9007199254740992.0;
  }
  return v;
}

Tensor leaf(std::vector<double> v, const Shape& shape, DType dtype) {
  Tensor t = Tensor::from_values(std::move(v), shape, dtype);
  t.set_requires_grad();
  return t;
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
  std::vector<double> x = values(3 * n, lo, hi, seed), z = values(3 * n, lo, hi, seed + 1);
  for (std::int64_t e = 0; e < 60 && e < 3 * n; ++e) z[std::size_t(e)] = x[std::size_t(e)];  // ties
  return {{leaf(x, {n, 3}, dtype), leaf(z, {n, 3}, dtype), leaf(values(n, lo, hi, seed + 2), {n, 1}, dtype)},
          {leaf(values(3, lo, hi, seed + 3), {3}, dtype), leaf(values(1, lo, hi, seed + 4), {}, dtype)}};
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

struct Run {
  Tensor out;
  std::vector<Tensor> grads;  // rows' gradients
};

// f's output and the rows' gradients of sum(out * w) for a fixed random w.
Run run(const Case& c, const std::function<Tensor()>& f) {
  for (Tensor t : c.rows) t.zero_grad();
  for (Tensor t : c.shared) t.zero_grad();
  Run result{f(), {}};
  const Tensor w = Tensor::from_values(values(result.out.numel(), -1, 1, 9), result.out.shape(), result.out.dtype());
  backward(sum(result.out * w));
  for (const Tensor& t : c.rows) result.grads.push_back(t.has_grad() ? t.grad() : Tensor::zeros(t.shape(), t.dtype()));
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
        for (std::size_t i : {0, 1}) {
          std::vector<double> v = c.rows[i].to_vector();
          for (std::size_t e = 0; e < 12; ++e) v[e] = 0;
          c.rows[i] = leaf(v, c.rows[i].shape(), dtype);
        }
      for (const OpId op : table_entries()) {
          const RowFunction f = graph_of(op);
          INFO(detail::op_name(op) << ", " << d.name << ", " << dtype_name(dtype));
          REQUIRE(map_rows_fuses(f, c.rows, c.shared, MapRowsOptions{kBlock}));
          const Run eager = run(c, [&] { return f(c.rows, c.shared); });
          const Run fused = run(c, [&] { return map_rows(f, c.rows, c.shared, MapRowsOptions{kBlock}); });
          // Strictly the same bits where no NaN arises.
          auto same = [&](const Tensor& x, const Tensor& y) { return d.zeros ? same_bits_or_nan(x, y) : same_bits(x, y); };
          CHECK(same(fused.out, eager.out));
          for (std::size_t i = 0; i < c.rows.size(); ++i) {
            INFO("rows[" << i << "]");
            CHECK(same(fused.grads[i], eager.grads[i]));
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
  for (std::size_t i = 0; i < in.size(); ++i) {
    std::vector<double> v = in[i].to_vector();
    for (double& x : v) x = 0.25 + 0.01 * std::floor((x - 0.25) / 0.01) + offsets[i];
    in[i] = leaf(v, in[i].shape(), DType::Float64);
  }
  for (const OpId op : table_entries()) {
    const RowFunction f = graph_of(op);
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
}
