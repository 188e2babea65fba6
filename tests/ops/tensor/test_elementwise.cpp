#include <catch2/catch.hpp>

#include <cmath>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {
using Inputs = std::vector<Tensor>;

Tensor grad_of(const std::function<Tensor(const Tensor&)>& f, const std::vector<double>& x) {
  Tensor t = Tensor::from_values(x, {static_cast<std::int64_t>(x.size())}, DType::Float64).set_requires_grad();
  backward(sum(f(t)));
  return t.grad();
}
}  // namespace

// One gradcheck test per binary op, with operands broadcast along rows,
// columns and from rank 0 (either side).
#define BINARY_GRADCHECK_TEST(op, expr, lo_b, hi_b)                                              \
  TEST_CASE(#op ": gradient matches finite differences with broadcasting", "[ops][elementwise][gradcheck]") { \
    Tensor a = random_input({4, 3}, -2, 2, 1);                                                   \
    for (const Shape& shape_b : {Shape{4, 3}, Shape{3}, Shape{4, 1}, Shape{}}) {                 \
      Tensor b = random_input(shape_b, lo_b, hi_b, 2);                                           \
      require_gradcheck(#op " " + shape_b.str(), [](const Inputs& in) {                          \
        const Tensor& x = in[0];                                                                 \
        const Tensor& y = in[1];                                                                 \
        return expr;                                                                             \
      }, {a, b});                                                                                \
    }                                                                                            \
    /* a rank-0 first operand against a full second one */                                     \
    Tensor s = random_input({}, -2, 2, 3), full_b = random_input({4, 3}, lo_b, hi_b, 4);         \
    require_gradcheck(#op " scalar first", [](const Inputs& in) {                                \
      const Tensor& x = in[0];                                                                   \
      const Tensor& y = in[1];                                                                   \
      return expr;                                                                               \
    }, {s, full_b});                                                                             \
  }

BINARY_GRADCHECK_TEST(add, x + y, -2, 2)
BINARY_GRADCHECK_TEST(sub, x - y, -2, 2)
BINARY_GRADCHECK_TEST(mul, x * y, -2, 2)
BINARY_GRADCHECK_TEST(div, x / y, 0.5, 2)
BINARY_GRADCHECK_TEST(minimum, minimum(x, y), -2, 2)
BINARY_GRADCHECK_TEST(maximum, maximum(x, y), -2, 2)

TEST_CASE("add and mul: forward values follow NumPy broadcasting", "[ops][elementwise]") {
  Tensor a = Tensor::from_values({1, 2, 3, 4, 5, 6}, {2, 3});
  Tensor col = Tensor::from_values({10, 20}, {2, 1});
  CHECK((a + col).to_vector() == std::vector<double>{11, 12, 13, 24, 25, 26});
  Tensor row = Tensor::from_values({1, 0, -1}, {1, 3});
  CHECK((a * row).to_vector() == std::vector<double>{1, 0, -3, 4, 0, -6});
  CHECK((col + row).shape() == Shape{2, 3});
}

TEST_CASE("a row operand against many rows gives every element, on either side, float32 and float64",
          "[ops][elementwise]") {
  for (DType dtype : {DType::Float32, DType::Float64})
    for (std::int64_t k : {3, 5})
      for (std::int64_t rows : {1, 255, 257, 70000}) {
        const Tensor m = Tensor::uniform({rows, k}, -2, 2, 7, dtype), v = Tensor::uniform({k}, -2, 2, 8, dtype);
        const std::vector<double> mv = m.to_vector(), vv = v.to_vector(), d1 = (v - m).to_vector(),
                                  d2 = (m - v).to_vector();
        bool all_equal = true;
        for (std::int64_t e = 0; e < rows * k; ++e) {
          const double a = vv[e % k] - mv[e], b = mv[e] - vv[e % k];
          all_equal &= dtype == DType::Float32 ? d1[e] == double(float(a)) && d2[e] == double(float(b))
                                                : d1[e] == a && d2[e] == b;
        }
        CHECK(all_equal);
      }
}

TEST_CASE("a column operand against many rows gives every element and gradient, on either side, float32 and float64",
          "[ops][elementwise]") {
  // [rows, k] with [rows, 1]: the forward spreads the column over blocks of rows,
  // the adjoint reads it per row; both must equal the per-element formulas. For
  // float32 each operation is done in double and rounded, which gives float's
  // own result (double rounding is harmless for + - * / with 53 >= 2 * 24 + 2 bits).
  for (DType dtype : {DType::Float32, DType::Float64})
    for (std::int64_t k : {1, 3, 5, 1000})
      for (std::int64_t rows : {1, 255, 257, 3000}) {
        if (k * rows > 400000) continue;
        Tensor m = Tensor::uniform({rows, k}, 0.5, 2, 9, dtype), c = Tensor::uniform({rows, 1}, 0.5, 2, 10, dtype);
        m.set_requires_grad();
        c.set_requires_grad();
        const Tensor g = Tensor::uniform({rows, k}, -1, 1, 11, dtype);
        const Tensor product = c * m, quotient = m / c;
        backward(sum(product * g) + sum(quotient * g));  // each receives exactly g
        auto round = [&](double x) { return dtype == DType::Float32 ? double(float(x)) : x; };
        const std::vector<double> mv = m.to_vector(), cv = c.to_vector(), gv = g.to_vector(), pv = product.to_vector(),
                                  qv = quotient.to_vector(), gm = m.grad().to_vector(), gc = c.grad().to_vector();
        bool all_equal = true;
        for (std::int64_t r = 0; r < rows; ++r) {
          double column_sum_mul = 0, column_sum_div = 0;
          for (std::int64_t j = 0; j < k; ++j) {
            const std::int64_t e = r * k + j;
            all_equal &= pv[e] == round(cv[r] * mv[e]) && qv[e] == round(mv[e] / cv[r]);
            // dm = g c + g / c; dc = sum_j g m (mul), sum_j -g y / c (div), each summed in double.
            all_equal &= gm[e] == round(round(gv[e] * cv[r]) + round(gv[e] / cv[r]));
            column_sum_mul += round(gv[e] * mv[e]);
            column_sum_div += round(-round(gv[e] * qv[e]) / cv[r]);
          }
          all_equal &= gc[r] == round(round(column_sum_mul) + round(column_sum_div));
        }
        CHECK(all_equal);
      }
}

TEST_CASE("a [3] operand's gradient from [N, 3] is summed per block of 4096 rows, blocks in order", "[ops][elementwise]") {
  // The sum behind a light's gradient: rows in blocks of kSumBlock, each summed in
  // double from 0, then the blocks added in order, rounded once.
  const std::int64_t rows = 3 * 4096 + 77;
  Tensor light = Tensor::from_values({1, 2, 3}, {3});
  light.set_requires_grad();
  const Tensor p = Tensor::uniform({rows, 3}, -1, 1, 12), g = Tensor::uniform({rows, 3}, -1, 1, 13);
  backward(light - p, g);
  const std::vector<double> gv = g.to_vector(), got = light.grad().to_vector();
  for (int j = 0; j < 3; ++j) CHECK(got[j] == double(float(gr::testing::blocked_column_sum(gv, rows, 3, j))));
}

// One gradcheck test per unary op, on random inputs inside its domain.
#define UNARY_GRADCHECK_TEST(op, expr, lo, hi)                                                  \
  TEST_CASE(#op ": gradient matches finite differences", "[ops][elementwise][gradcheck]") {    \
    Tensor x = random_input({2, 5}, lo, hi, 5);                                                 \
    require_gradcheck(#op, [](const Inputs& in) { const Tensor& a = in[0]; return expr; }, {x}); \
  }

UNARY_GRADCHECK_TEST(neg, neg(a), -3, 3)
UNARY_GRADCHECK_TEST(exp, exp(a), -3, 3)
UNARY_GRADCHECK_TEST(log, log(a), 0.2, 2)
UNARY_GRADCHECK_TEST(sqrt, sqrt(a), 0.2, 2)
UNARY_GRADCHECK_TEST(rsqrt, rsqrt(a), 0.2, 2)
UNARY_GRADCHECK_TEST(sin, sin(a), -3, 3)
UNARY_GRADCHECK_TEST(cos, cos(a), -3, 3)
UNARY_GRADCHECK_TEST(abs, abs(a), -3, 3)
UNARY_GRADCHECK_TEST(clamp, clamp(a, -1.0, 1.5), -3, 3)

TEST_CASE("pow: gradient matches finite differences for scalar and tensor exponents", "[ops][elementwise][gradcheck]") {
  Tensor x = random_input({6}, 0.3, 1.5, 7);
  Tensor p = random_input({6}, -1.5, 2.5, 8);
  require_gradcheck("pow integer", [](const Inputs& in) { return pow(in[0], 32.0); }, {x});
  require_gradcheck("pow negative integer", [](const Inputs& in) { return pow(in[0], -3.0); }, {x});
  require_gradcheck("pow fractional", [](const Inputs& in) { return pow(in[0], 0.37); }, {x});
  require_gradcheck("pow tensor", [](const Inputs& in) { return pow(in[0], in[1]); }, {x, p});
  Tensor neg_base = random_input({4}, -2, -0.5, 9);
  require_gradcheck("pow integer on negative base", [](const Inputs& in) { return pow(in[0], 3.0); }, {neg_base});
}

// x^n as repeated squaring does it one element at a time, in T: r = 1, b = x;
// per bit of n from the lowest, r *= b if set, b *= b if a higher bit follows.
template <class T>
T squaring_power(T x, long long n) {
  T r = T(1), b = x;
  for (long long e = n; e > 0; e >>= 1) {
    if (e & 1) r *= b;
    if (e > 1) b *= b;
  }
  return r;
}

TEST_CASE("pow: integer exponents give repeated squaring's products bit for bit, at lengths across vector blocks",
          "[ops][elementwise]") {
  for (DType dtype : {DType::Float32, DType::Float64})
    for (std::int64_t n : {0, 1, 7, 31, 32, 33, 64, 100, 1000})
      for (double p : {0.0, 1.0, 2.0, 3.0, 5.0, 31.0, 32.0, 64.0, -3.0}) {
        INFO(dtype_name(dtype) << ", " << n << " elements, p = " << p);
        const Tensor x = Tensor::uniform({n}, -1.5, 1.5, 20 + std::uint64_t(n), dtype);
        const std::vector<double> got = pow(x, p).to_vector(), in = x.to_vector();
        std::vector<double> want(in.size());
        for (std::size_t i = 0; i < in.size(); ++i) {
          const long long e = static_cast<long long>(std::fabs(p));
          if (dtype == DType::Float32) {
            const float r = squaring_power(float(in[i]), e);
            want[i] = p < 0 ? double(1.0f / r) : double(r);
          } else {
            const double r = squaring_power(in[i], e);
            want[i] = p < 0 ? 1.0 / r : r;
          }
        }
        CHECK(gr::testing::same_bits(got, want));
      }
}

TEST_CASE("pow: integer exponents agree with std::pow", "[ops][elementwise]") {
  Tensor x = Tensor::uniform({100}, -2, 2, 10, DType::Float64);
  for (double p : {0.0, 1.0, 2.0, 5.0, 32.0, -2.0}) {
    std::vector<double> got = pow(x, p).to_vector(), in = x.to_vector();
    for (std::size_t i = 0; i < in.size(); ++i) CHECK(got[i] == Approx(std::pow(in[i], p)).epsilon(1e-13));
  }
}

TEST_CASE("where: gradient matches finite differences and goes to the selected operand only", "[ops][elementwise][gradcheck]") {
  Tensor a = random_input({2, 3}, -1, 1, 13);
  Tensor b = random_input({3}, -1, 1, 14);
  Tensor mask = Tensor::from_values({1, 0, 1, 0, 0, 1}, {2, 3}, DType::Float64);
  require_gradcheck("where", [&](const Inputs& in) { return where(mask, in[0], in[1]); }, {a, b});
  Tensor x = Tensor::from_values({1, 2, 3}, {3}, DType::Float64);
  Tensor m = greater(x, Tensor::scalar(1.5, DType::Float64));
  CHECK(m.to_vector() == std::vector<double>{0, 1, 1});
  CHECK(where(m, x, -x).to_vector() == std::vector<double>{-1, 2, 3});
}

TEST_CASE("comparison masks are 0/1 in the operands' dtype", "[ops][elementwise]") {
  Tensor a = Tensor::from_values({1, 2, 3}, {3});
  Tensor b = Tensor::from_values({2, 2, 2}, {3});
  CHECK(less(a, b).to_vector() == std::vector<double>{1, 0, 0});
  CHECK(less_equal(a, b).to_vector() == std::vector<double>{1, 1, 0});
  CHECK(greater(a, b).to_vector() == std::vector<double>{0, 0, 1});
  CHECK(greater_equal(a, b).to_vector() == std::vector<double>{0, 1, 1});
  CHECK(equal(a, b).to_vector() == std::vector<double>{0, 1, 0});
  CHECK(not_equal(a, b).to_vector() == std::vector<double>{1, 0, 1});
}

TEST_CASE("cast: gradient matches finite differences and flows between float32 and float64", "[ops][elementwise][gradcheck]") {
  Tensor x = random_input({5}, -1, 1, 15);
  require_gradcheck("cast", [](const Inputs& in) { return cast(in[0] * 3.0, DType::Float64); }, {x});
  // Through float32 and back, the gradient is cast back exactly: 3 per element.
  backward(sum(cast(cast(x, DType::Float32) * 3.0, DType::Float64)));
  CHECK(x.grad().to_vector() == std::vector<double>(5, 3.0));
  Tensor i = cast(Tensor::from_values({1.7, -2.2}, {2}), DType::Int32);
  CHECK(i.to_vector() == std::vector<double>{1, -2});
}

TEST_CASE("hard cases: sqrt and fractional pow at exactly zero have a zero, finite gradient", "[ops][elementwise][hard]") {
  CHECK(grad_of([](const Tensor& t) { return sqrt(t); }, {0.0, 4.0}).to_vector() == std::vector<double>{0.0, 0.25});
  CHECK(grad_of([](const Tensor& t) { return pow(t, 0.5); }, {0.0}).to_vector() == std::vector<double>{0.0});
  CHECK(grad_of([](const Tensor& t) { return pow(t, 0.25); }, {0.0}).to_vector() == std::vector<double>{0.0});
  // p >= 1 keeps its true derivative at 0.
  CHECK(grad_of([](const Tensor& t) { return pow(t, 1.0); }, {0.0}).to_vector() == std::vector<double>{1.0});
  CHECK(grad_of([](const Tensor& t) { return pow(t, 2.0); }, {0.0}).to_vector() == std::vector<double>{0.0});
  // Tensor exponent: base 0 -> dL/d(exponent) = 0 instead of 0 * -inf.
  Tensor base = Tensor::from_values({0.0}, {1}, DType::Float64).set_requires_grad();
  Tensor e = Tensor::from_values({0.5}, {1}, DType::Float64).set_requires_grad();
  backward(sum(pow(base, e)));
  CHECK(base.grad().item() == 0.0);
  CHECK(e.grad().item() == 0.0);
  // Near zero, the smooth derivative is still checked.
  Tensor x = random_input({4}, 1e-4, 1e-3, 16);
  require_gradcheck("sqrt near zero", [](const Inputs& in) { return sqrt(in[0]); }, {x}, GradcheckOptions{1e-9, 1e-7, 1e-5});
}

TEST_CASE("hard cases: division by tiny numbers gives finite, exact gradients", "[ops][elementwise][hard]") {
  // In float32 b^2 = 1e-40 underflows; computing -(g a/b)/b keeps the result representable.
  Tensor a = Tensor::from_values({1e-10}, {1}).set_requires_grad();
  Tensor b = Tensor::from_values({1e-20}, {1}).set_requires_grad();
  backward(sum(a / b));
  CHECK(all_finite(b.grad()));
  CHECK(b.grad().item() == Approx(-1e30).epsilon(1e-5));
  CHECK(a.grad().item() == Approx(1e20).epsilon(1e-5));
  // One finite-difference step cannot suit operands of size 1e-8 and 1, so
  // each operand is checked with a step matched to its size.
  Tensor x = random_input({3}, 1e-8, 2e-8, 17);
  Tensor y = Tensor::uniform({3}, 1, 2, 18, DType::Float64);
  require_gradcheck("div by tiny (divisor)", [&](const Inputs& in) { return y / in[0]; }, {x},
                    GradcheckOptions{1e-15, 1e-7, 1e-6});
  require_gradcheck("div by tiny (dividend)", [&](const Inputs& in) { return in[0] / x.detach(); }, {y.copy().set_requires_grad()});
}

TEST_CASE("hard cases: min, max and clamp at ties split or pass the gradient as documented", "[ops][elementwise][hard]") {
  Tensor a = Tensor::from_values({1, 2}, {2}, DType::Float64).set_requires_grad();
  Tensor b = Tensor::from_values({1, 3}, {2}, DType::Float64).set_requires_grad();
  backward(sum(maximum(a, b)));
  CHECK(a.grad().to_vector() == std::vector<double>{0.5, 0});
  CHECK(b.grad().to_vector() == std::vector<double>{0.5, 1});
  a.zero_grad();
  b.zero_grad();
  backward(sum(minimum(a, b)));
  CHECK(a.grad().to_vector() == std::vector<double>{0.5, 1});
  CHECK(b.grad().to_vector() == std::vector<double>{0.5, 0});
  // clamp: bounds are inclusive for the gradient.
  CHECK(grad_of([](const Tensor& t) { return clamp(t, 0.0, 1.0); }, {0.0, 1.0, 1.5, -0.1}).to_vector() ==
        std::vector<double>{1, 1, 0, 0});
  // abs: zero gradient at zero.
  CHECK(grad_of([](const Tensor& t) { return abs(t); }, {0.0, -2.0}).to_vector() == std::vector<double>{0, -1});
}

TEST_CASE("elementwise errors name both shapes, the dtype or the bad argument", "[ops][elementwise][errors]") {
  Tensor a = Tensor::ones({2, 3});
  Tensor b = Tensor::ones({4});
  CHECK_THROWS_AS(a + b, ShapeError);
  CHECK_THROWS_WITH(a * b, Catch::Contains("[2, 3]") && Catch::Contains("[4]") && Catch::Contains("mul"));
  Tensor i = Tensor::ones({2, 3}, DType::Int32);
  CHECK_THROWS_AS(exp(i), DTypeError);
  CHECK_THROWS_AS(a - i, DTypeError);
  CHECK_THROWS_AS(clamp(a, 1.0, 0.0), ValueError);
  CHECK_THROWS_AS(exp(Tensor()), ValueError);
}

TEST_CASE("elementwise results are bit-identical for 1 and 2 threads", "[ops][elementwise][determinism]") {
  Tensor a = Tensor::uniform({300000}, 0.1, 2, 19).set_requires_grad();
  Tensor b = Tensor::uniform({3}, 0.1, 2, 20).set_requires_grad();
  auto eval = [&](int threads) {
    set_num_threads(threads);
    a.zero_grad();
    b.zero_grad();
    Tensor loss = sum(pow(a, 3.0) * exp(-a) + sqrt(a) / sum(b));
    backward(loss);
    std::vector<double> r = {loss.item()};
    for (double g : a.grad().to_vector()) r.push_back(g);
    for (double g : b.grad().to_vector()) r.push_back(g);
    return r;
  };
  const auto one = eval(1), two = eval(2);
  set_num_threads(0);
  CHECK(one == two);
}

// ---- Conveniences: scalar comparisons, comparison operators, dtype promotion ----

TEST_CASE("comparisons with a number give the same masks as comparisons with a scalar tensor", "[ops][compare]") {
  const Tensor t = Tensor::from_values({-1, 0, 2}, {3});
  CHECK(greater(t, 0.0).to_vector() == std::vector<double>{0, 0, 1});
  CHECK(greater_equal(t, 0.0).to_vector() == std::vector<double>{0, 1, 1});
  CHECK(less(t, 0.0).to_vector() == std::vector<double>{1, 0, 0});
  CHECK(less_equal(t, 0.0).to_vector() == std::vector<double>{1, 1, 0});
  CHECK(equal(t, 2.0).to_vector() == std::vector<double>{0, 0, 1});
  CHECK(not_equal(t, 2.0).to_vector() == std::vector<double>{1, 1, 0});
  CHECK(greater(t, 0.0).dtype() == DType::Float32);
}

TEST_CASE("comparison operators give masks for tensor-tensor, tensor-number and number-tensor", "[ops][compare]") {
  const Tensor a = Tensor::from_values({1, 2, 3}, {3}, DType::Float64);
  const Tensor b = Tensor::from_values({3, 2, 1}, {3}, DType::Float64);
  using V = std::vector<double>;
  CHECK((a < b).to_vector() == V{1, 0, 0});
  CHECK((a <= b).to_vector() == V{1, 1, 0});
  CHECK((a > b).to_vector() == V{0, 0, 1});
  CHECK((a >= b).to_vector() == V{0, 1, 1});
  CHECK((a == b).to_vector() == V{0, 1, 0});
  CHECK((a != b).to_vector() == V{1, 0, 1});
  CHECK((a < 2.0).to_vector() == V{1, 0, 0});
  CHECK((a >= 2.0).to_vector() == V{0, 1, 1});
  CHECK((a == 3.0).to_vector() == V{0, 0, 1});
  CHECK((2.0 < a).to_vector() == V{0, 0, 1});  // reads as "2 < a"
  CHECK((2.0 >= a).to_vector() == V{1, 1, 0});
  CHECK((2.0 != a).to_vector() == V{1, 0, 1});
  // A mask drives where() with no gradient through the comparison.
  Tensor x = Tensor::from_values({-2, 3}, {2}, DType::Float64).set_requires_grad();
  const Tensor relu = where(x > 0.0, x, zeros_like(x));
  CHECK(relu.to_vector() == V{0, 3});
}

TEST_CASE("float32 with float64 computes in float64, and the float32 operand's gradient comes back as float32",
          "[ops][promote]") {
  const Tensor a32 = Tensor::from_values({1.5, -2}, {2}, DType::Float32);
  const Tensor b64 = Tensor::from_values({0.25, 4}, {2}, DType::Float64);
  CHECK(promote_types(DType::Float32, DType::Float64) == DType::Float64);
  CHECK(promote_types(DType::Float32, DType::Float32) == DType::Float32);
  CHECK_THROWS_AS(promote_types(DType::Int32, DType::Float64), DTypeError);
  for (const Tensor& r : {a32 + b64, b64 - a32, a32 * b64, a32 / b64, pow(b64, a32), minimum(a32, b64),
                          maximum(b64, a32), greater(a32, b64), where(greater(a32, b64), a32, b64)})
    CHECK(r.dtype() == DType::Float64);
  CHECK((a32 * b64).to_vector() == std::vector<double>{0.375, -8});
  CHECK(matmul(reshape(a32, {1, 2}), reshape(b64, {2, 1})).dtype() == DType::Float64);
  CHECK((a32 * 0.5).dtype() == DType::Float32);  // a number does not promote

  Tensor p = Tensor::from_values({1.5, -2}, {2}).set_requires_grad();
  backward(sum(p * b64));
  REQUIRE(p.grad().dtype() == DType::Float32);
  CHECK(p.grad().to_vector() == std::vector<double>{0.25, 4});
  CHECK_THROWS_AS(add(a32, Tensor::ones({2}, DType::Int32)), DTypeError);
}

TEST_CASE("mixed-dtype ops have correct gradients for both operands (gradcheck)", "[ops][promote][gradcheck]") {
  // gradcheck perturbs float64 inputs; casting one of them to float32 inside f
  // makes the op see a float32 operand (the checks' tolerances allow for its rounding).
  GradcheckOptions o;
  o.eps = 1e-2;
  o.atol = 1e-4;
  o.rtol = 1e-3;
  const Tensor a = Tensor::uniform({3, 4}, 0.5, 2, 1, DType::Float64).set_requires_grad();
  const Tensor b = Tensor::uniform({4}, 0.5, 2, 2, DType::Float64).set_requires_grad();
  const Tensor m = Tensor::uniform({4, 2}, -1, 1, 3, DType::Float64).set_requires_grad();
  auto f32 = [](const Tensor& t) { return cast(t, DType::Float32); };
  for (auto& [name, f] : std::vector<std::pair<const char*, GradcheckFn>>{
           {"mul", [&](const std::vector<Tensor>& x) { return f32(x[0]) * x[1]; }},
           {"div", [&](const std::vector<Tensor>& x) { return x[0] / f32(x[1]); }},
           {"sub", [&](const std::vector<Tensor>& x) { return f32(x[0]) - x[1]; }},
           {"pow", [&](const std::vector<Tensor>& x) { return pow(f32(x[0]), x[1]); }},
           {"maximum", [&](const std::vector<Tensor>& x) { return maximum(x[0], f32(x[1])); }},
           {"where", [&](const std::vector<Tensor>& x) { return where(x[0] > 1.0, f32(x[0]), x[1]); }},
           {"matmul", [&](const std::vector<Tensor>& x) { return matmul(f32(x[0]), x[2]); }}}) {
    INFO(name);
    const GradcheckResult r = gradcheck(f, {a, b, m}, o);
    INFO(r.report());
    CHECK(r.passed);
  }
}
