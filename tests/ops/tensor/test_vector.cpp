// Tests of the vector ops (dot, cross, length, normalize, reflect): finite
// difference checks with broadcasting, hand-computed values, the documented
// gradients at and near zero length, and argument validation.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {
using Inputs = std::vector<Tensor>;

Tensor vec64(const std::vector<double>& v, const Shape& s) { return Tensor::from_values(v, s, DType::Float64); }
}  // namespace

// --- dot ---------------------------------------------------------------------

TEST_CASE("dot: gradient matches finite differences with broadcast leading axes", "[ops][vector][gradcheck]") {
  Tensor a = random_input({5, 3}, -2, 2, 11);
  Tensor b = random_input({5, 3}, -2, 2, 12);
  require_gradcheck("dot", [](const Inputs& in) { return dot(in[0], in[1]); }, {a, b});
  Tensor c = random_input({4, 1, 3}, -2, 2, 13);
  Tensor d = random_input({2, 3}, -2, 2, 14);
  require_gradcheck("dot broadcast", [](const Inputs& in) { return dot(in[0], in[1]); }, {c, d});
  Tensor e = random_input({3, 7}, -1, 1, 15);
  Tensor f = random_input({7}, -1, 1, 16);
  require_gradcheck("dot length-7 vectors", [](const Inputs& in) { return dot(in[0], in[1]); }, {e, f});
}

TEST_CASE("dot: sums products over the last axis and keeps it with extent 1", "[ops][vector]") {
  Tensor a = vec64({1, 2, 3, 0, 1, 0}, {2, 3});
  Tensor b = vec64({4, 5, 6}, {3});
  Tensor r = dot(a, b);
  CHECK(r.shape() == Shape{2, 1});
  CHECK(r.to_vector() == std::vector<double>{32, 5});
  Tensor f = dot(Tensor::from_values({1, 2, 3}, {3}), Tensor::from_values({4, 5, 6}, {3}));
  CHECK(f.shape() == Shape{1});
  CHECK(f.item() == 32.0);
}

TEST_CASE("dot: mismatched vector lengths, shapes and dtypes are rejected", "[ops][vector][errors]") {
  Tensor a = Tensor::zeros({4, 3});
  CHECK_THROWS_AS(dot(a, Tensor::zeros({4, 2})), ShapeError);
  CHECK_THROWS_WITH(dot(a, Tensor::zeros({4, 2})), Catch::Contains("[4, 3]") && Catch::Contains("[4, 2]"));
  CHECK_THROWS_WITH(dot(a, Tensor::zeros({5, 3})), Catch::Contains("[4, 3]") && Catch::Contains("[5, 3]"));
  CHECK_THROWS_AS(dot(a, Tensor::zeros({4, 3}, DType::Float64)), DTypeError);
  CHECK_THROWS_AS(dot(a, Tensor::zeros({4, 3}, DType::Int32)), DTypeError);
  CHECK_THROWS_AS(dot(Tensor::scalar(1), Tensor::scalar(1)), ShapeError);
}

// --- cross -------------------------------------------------------------------

TEST_CASE("cross: gradient matches finite differences, including broadcasting", "[ops][vector][gradcheck]") {
  Tensor a = random_input({6, 3}, -2, 2, 21);
  Tensor b = random_input({6, 3}, -2, 2, 22);
  require_gradcheck("cross", [](const Inputs& in) { return cross(in[0], in[1]); }, {a, b});
  Tensor c = random_input({2, 1, 3}, -2, 2, 23);
  Tensor d = random_input({4, 3}, -2, 2, 24);
  require_gradcheck("cross broadcast", [](const Inputs& in) { return cross(in[0], in[1]); }, {c, d});
}

TEST_CASE("cross: right-handed basis and parallel vectors", "[ops][vector]") {
  Tensor x = vec64({1, 0, 0}, {3}), y = vec64({0, 1, 0}, {3});
  CHECK(cross(x, y).to_vector() == std::vector<double>{0, 0, 1});
  CHECK(cross(y, x).to_vector() == std::vector<double>{0, 0, -1});
  CHECK(cross(vec64({1, 2, 3}, {3}), vec64({4, 5, 6}, {3})).to_vector() == std::vector<double>{-3, 6, -3});

  // Parallel vectors: zero product, and the gradient is still b x g and g x a.
  Tensor a = vec64({1, 2, 3}, {3}).set_requires_grad();
  Tensor b = vec64({2, 4, 6}, {3}).set_requires_grad();
  Tensor c = cross(a, b);
  CHECK(c.to_vector() == std::vector<double>{0, 0, 0});
  Tensor g = vec64({1, 0, 0}, {3});
  backward(c, g);
  CHECK(a.grad().to_vector() == std::vector<double>{0, 6, -4});   // b x g
  CHECK(b.grad().to_vector() == std::vector<double>{0, -3, 2});   // g x a
  require_gradcheck("cross parallel", [](const Inputs& in) { return cross(in[0], in[1]); },
                    {vec64({1, 2, 3}, {3}).set_requires_grad(), vec64({2, 4, 6}, {3}).set_requires_grad()});
}

TEST_CASE("cross: a last axis other than 3 is rejected", "[ops][vector][errors]") {
  CHECK_THROWS_AS(cross(Tensor::zeros({4, 2}), Tensor::zeros({4, 2})), ShapeError);
  CHECK_THROWS_WITH(cross(Tensor::zeros({4, 4}), Tensor::zeros({4, 3})),
                    Catch::Contains("cross") && Catch::Contains("3") && Catch::Contains("[4, 4]"));
  CHECK_THROWS_AS(cross(Tensor::zeros({2, 3}), Tensor::zeros({3, 3})), ShapeError);
  CHECK_THROWS_AS(cross(Tensor::zeros({3}), Tensor::zeros({3}, DType::Float64)), DTypeError);
}

// --- length ------------------------------------------------------------------

TEST_CASE("length: gradient matches finite differences for random and tiny vectors", "[ops][vector][gradcheck]") {
  Tensor v = random_input({5, 3}, -2, 2, 31);
  require_gradcheck("length", [](const Inputs& in) { return length(in[0]); }, {v});
  Tensor tiny = random_input({4, 3}, -1e-3, 1e-3, 32);
  GradcheckOptions opt;
  opt.eps = 1e-8;
  require_gradcheck("length near zero", [](const Inputs& in) { return length(in[0]); }, {tiny}, opt);
}

TEST_CASE("length: values, and a zero gradient at the zero vector", "[ops][vector]") {
  Tensor v = vec64({3, 4, 0, 0, 0, 0}, {2, 3}).set_requires_grad();
  Tensor l = length(v);
  CHECK(l.shape() == Shape{2, 1});
  CHECK(l.to_vector() == std::vector<double>{5, 0});
  backward(sum(l));
  CHECK(all_finite(v.grad()));
  std::vector<double> gv = v.grad().to_vector();
  CHECK(gv[0] == Approx(0.6));
  CHECK(gv[1] == Approx(0.8));
  CHECK(std::vector<double>(gv.begin() + 2, gv.end()) == std::vector<double>{0, 0, 0, 0});  // exactly 0 at v == 0
  // float32 vectors far below sqrt(FLT_MIN) still have a nonzero length.
  Tensor t = Tensor::from_values({3e-25, 4e-25}, {2});
  CHECK(length(t).item() == Approx(5e-25).epsilon(1e-6));
}

TEST_CASE("dot: a [3] operand against rows of 3 equals its expanded copy, values and gradients, on either side",
          "[ops][vector]") {
  // The single row is read in place, never copied to [N, 3]; nothing may change.
  for (DType dtype : {DType::Float32, DType::Float64})
    for (std::int64_t rows : {1, 127, 129, 9000})
      for (bool row_first : {true, false}) {
        const Tensor m = Tensor::uniform({rows, 3}, -2, 2, 50, dtype), v = Tensor::uniform({3}, -2, 2, 51, dtype);
        const Tensor g = Tensor::uniform({rows, 1}, -1, 1, 52, dtype);
        Tensor m1 = m.copy().set_requires_grad(), v1 = v.copy().set_requires_grad();
        Tensor m2 = m.copy().set_requires_grad();
        Tensor ve = concat(std::vector<Tensor>(static_cast<std::size_t>(rows), reshape(v, {1, 3})), 0).set_requires_grad();
        const Tensor in_place = row_first ? dot(v1, m1) : dot(m1, v1), expanded = row_first ? dot(ve, m2) : dot(m2, ve);
        CHECK(in_place.to_vector() == expanded.to_vector());
        backward(sum(in_place * g) + sum(expanded * g));  // two graphs with their own leaves
        CHECK(m1.grad().to_vector() == m2.grad().to_vector());
        // v's gradient: the expanded copy's rows summed as any [N, 3] -> [3] is.
        const std::vector<double> gve = ve.grad().to_vector(), gv = v1.grad().to_vector();
        for (int j = 0; j < 3; ++j) {
          const double total = gr::testing::blocked_column_sum(gve, rows, 3, j);
          CHECK(gv[j] == (dtype == DType::Float32 ? double(float(total)) : total));
        }
      }
}

// --- normalize ---------------------------------------------------------------

TEST_CASE("normalize: gradient matches finite differences for random vectors", "[ops][vector][gradcheck]") {
  Tensor v = random_input({6, 3}, -2, 2, 41);
  require_gradcheck("normalize", [](const Inputs& in) { return normalize(in[0]); }, {v});
  Tensor w = random_input({2, 2, 5}, -2, 2, 42);
  require_gradcheck("normalize length-5", [](const Inputs& in) { return normalize(in[0]); }, {w});
}

TEST_CASE("normalize: gradient matches finite differences near zero length", "[ops][vector][gradcheck]") {
  // |v| ~ 1e-3: Jacobian entries ~ 1e3, still smooth at the scale of the step.
  Tensor v = random_input({4, 3}, -1e-3, 1e-3, 43);
  GradcheckOptions opt;
  opt.eps = 1e-9;
  opt.rtol = 1e-5;
  require_gradcheck("normalize near zero", [](const Inputs& in) { return normalize(in[0]); }, {v}, opt);
  // Below eps the op is v / eps, a linear map.
  Tensor u = random_input({3, 3}, -1e-5, 1e-5, 44);
  require_gradcheck("normalize below eps", [](const Inputs& in) { return normalize(in[0], 1e-3); }, {u}, opt);
}

TEST_CASE("normalize: rows of 3 give the per-row formulas' bits, float32 and float64, across block edges",
          "[ops][vector]") {
  // Forward v / d with d = max(sqrt(x^2 + y^2 + z^2), eps) (float32: v times the double 1 / d);
  // adjoint (g - n (n.g)) / d, or g / eps at or below eps; each in double, rounded once.
  for (DType dtype : {DType::Float32, DType::Float64})
    for (std::int64_t rows : {1, 127, 128, 129, 1000}) {
      Tensor v = Tensor::uniform({rows, 3}, -3, 3, 45, dtype);
      if (rows > 2) v = concat({slice(v, 0, 0, rows - 2), Tensor::zeros({2, 3}, dtype)}, 0);  // zero rows: / eps
      v.set_requires_grad();
      const Tensor g = Tensor::uniform({rows, 3}, -1, 1, 46, dtype);
      const Tensor n = normalize(v);
      backward(n, g);
      const std::vector<double> in = v.to_vector(), out = n.to_vector(), gin = g.to_vector(),
                                gout = v.grad().to_vector();
      auto round = [&](double x) { return dtype == DType::Float32 ? double(float(x)) : x; };
      for (std::int64_t r = 0; r < rows; ++r) {
        const double x = in[3 * r], y = in[3 * r + 1], z = in[3 * r + 2];
        const double d = std::max(std::sqrt(x * x + y * y + z * z), kNormalizeEps);
        const double stored_d = round(d);
        double ng = 0;
        for (int j = 0; j < 3; ++j) ng += out[3 * r + j] * gin[3 * r + j];
        for (int j = 0; j < 3; ++j) {
          REQUIRE(out[3 * r + j] == (dtype == DType::Float32 ? round(in[3 * r + j] * (1 / d)) : in[3 * r + j] / d));
          const double expected = stored_d > round(kNormalizeEps)
                                      ? round((gin[3 * r + j] - out[3 * r + j] * ng) * (1 / stored_d))
                                      : round(gin[3 * r + j] / kNormalizeEps);
          REQUIRE(gout[3 * r + j] == expected);
        }
      }
    }
}

TEST_CASE("normalize: float32 results are the correctly rounded quotients, exact ones included", "[ops][vector]") {
  // The float32 path multiplies by 1 / d in double; rounding to float hides that on these rows.
  const std::int64_t rows = 100000;
  const Tensor v = Tensor::uniform({rows, 3}, -3, 3, 47, DType::Float32);
  const std::vector<double> in = v.to_vector(), out = normalize(v).to_vector();
  std::int64_t differing = 0;
  for (std::int64_t r = 0; r < rows; ++r) {
    const double x = in[3 * r], y = in[3 * r + 1], z = in[3 * r + 2], d = std::sqrt(x * x + y * y + z * z);
    for (int j = 0; j < 3; ++j) differing += out[3 * r + j] != double(float(in[3 * r + j] / d));
  }
  CHECK(differing == 0);
  CHECK(normalize(Tensor::from_values({3, 4, 0}, {3})).to_vector() == std::vector<double>{0.6f, 0.8f, 0});
}

TEST_CASE("normalize: unit results, and the documented finite gradient g / eps at zero", "[ops][vector]") {
  Tensor v = vec64({3, 0, 4, 0, 0, 0}, {2, 3}).set_requires_grad();
  Tensor n = normalize(v);
  CHECK(n.to_vector() == std::vector<double>{0.6, 0, 0.8, 0, 0, 0});
  Tensor g = vec64({1, 2, 3, 1, 2, 3}, {2, 3});
  backward(n, g);
  std::vector<double> gv = v.grad().to_vector();
  CHECK(all_finite(v.grad()));
  // Row 0: (g - n (n.g)) / |v| with n.g = 3, |v| = 5.
  CHECK(gv[0] == Approx((1 - 0.6 * 3) / 5));
  CHECK(gv[1] == Approx(2.0 / 5));
  CHECK(gv[2] == Approx((3 - 0.8 * 3) / 5));
  // Row 1 (v == 0): g / eps exactly.
  CHECK(gv[3] == 1 / kNormalizeEps);
  CHECK(gv[4] == 2 / kNormalizeEps);
  CHECK(gv[5] == 3 / kNormalizeEps);

  // With a larger eps, the zero vector's gradient is g / eps = 1e3 g.
  Tensor z = Tensor::zeros({1, 3}, DType::Float64).set_requires_grad();
  backward(sum(normalize(z, 1e-3)));
  CHECK(z.grad().to_vector() == std::vector<double>{1e3, 1e3, 1e3});

  // float32 forward agrees with double.
  Tensor f = normalize(Tensor::from_values({1, 2, 2}, {3}));
  CHECK(f.dtype() == DType::Float32);
  CHECK(f.at({1}) == Approx(2.0 / 3));
}

TEST_CASE("length and normalize: a scalar or int32 argument is rejected", "[ops][vector][errors]") {
  CHECK_THROWS_AS(normalize(Tensor::scalar(1)), ShapeError);
  CHECK_THROWS_AS(length(Tensor::zeros({3}, DType::Int32)), DTypeError);
  CHECK_THROWS_WITH(normalize(Tensor::zeros({3}, DType::Int32)), Catch::Contains("normalize") && Catch::Contains("int32"));
  CHECK_THROWS_AS(normalize(Tensor::zeros({3}), 0.0), ValueError);
}

// --- reflect -----------------------------------------------------------------

TEST_CASE("reflect: gradient matches finite differences for both arguments", "[ops][vector][gradcheck]") {
  Tensor i = random_input({5, 3}, -1, 1, 51);
  Tensor n = random_input({5, 3}, -1, 1, 52);
  require_gradcheck("reflect", [](const Inputs& in) { return reflect(in[0], in[1]); }, {i, n});
  Tensor nb = random_input({3}, -1, 1, 53);  // one normal for all directions
  require_gradcheck("reflect broadcast", [](const Inputs& in) { return reflect(in[0], in[1]); }, {i, nb});
}

TEST_CASE("reflect: mirrors a direction about a unit normal", "[ops][vector]") {
  Tensor r = reflect(vec64({1, -1, 0}, {3}), vec64({0, 1, 0}, {3}));
  CHECK(r.to_vector() == std::vector<double>{1, 1, 0});
  CHECK_THROWS_WITH(reflect(Tensor::zeros({2, 3}), Tensor::zeros({2, 2})),
                    Catch::Contains("reflect") && Catch::Contains("[2, 3]") && Catch::Contains("[2, 2]"));
  CHECK_THROWS_AS(reflect(Tensor::zeros({3}), Tensor::zeros({3}, DType::Float64)), DTypeError);
}
