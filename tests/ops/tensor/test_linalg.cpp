// Tests of matmul, transpose, to_homogeneous and transform_points: finite
// difference checks (plain, batched, batch-broadcast, large inner dimensions),
// hand-computed products, thread-count independence, and shape errors.
#include <catch2/catch.hpp>

#include <cstring>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {
using Inputs = std::vector<Tensor>;

bool bit_identical(const Tensor& a, const Tensor& b) {
  return a.shape() == b.shape() && a.dtype() == b.dtype() &&
         std::memcmp(a.data<float>(), b.data<float>(), static_cast<std::size_t>(a.numel()) * sizeof(float)) == 0;
}

// Reference product of [n, k] x [k, m] float64 tensors.
std::vector<double> naive_matmul(const Tensor& a, const Tensor& b) {
  const std::int64_t n = a.size(0), k = a.size(1), m = b.size(1);
  std::vector<double> av = a.to_vector(), bv = b.to_vector(), c(static_cast<std::size_t>(n * m), 0.0);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t j = 0; j < m; ++j)
      for (std::int64_t p = 0; p < k; ++p) c[i * m + j] += av[i * k + p] * bv[p * m + j];
  return c;
}
}  // namespace

TEST_CASE("matmul: gradient matches finite differences for plain and batched products", "[ops][linalg][gradcheck]") {
  auto mm = [](const Inputs& in) { return matmul(in[0], in[1]); };
  require_gradcheck("matmul", mm, {random_input({3, 4}, -1, 1, 1), random_input({4, 5}, -1, 1, 2)});
  require_gradcheck("matmul batched", mm, {random_input({2, 3, 4}, -1, 1, 3), random_input({2, 4, 2}, -1, 1, 4)});
  // Batch broadcasting: [2, 1] x [3] batches -> [2, 3].
  require_gradcheck("matmul batch broadcast", mm,
                    {random_input({2, 1, 3, 4}, -1, 1, 5), random_input({3, 4, 2}, -1, 1, 6)});
  // A plain matrix against a batch (b's batches summed in dL/da).
  require_gradcheck("matmul matrix x batch", mm, {random_input({3, 4}, -1, 1, 7), random_input({2, 4, 3}, -1, 1, 8)});
  // A batch against a plain matrix (a's batches fold into rows).
  require_gradcheck("matmul batch x matrix", mm, {random_input({2, 5, 4}, -1, 1, 9), random_input({4, 4}, -1, 1, 10)});
  // Inner dimensions large enough for the Eigen path.
  require_gradcheck("matmul large inner", mm, {random_input({17, 16}, -1, 1, 11), random_input({16, 18}, -1, 1, 12)});
}

TEST_CASE("matmul: small hand-computed products, batched", "[ops][linalg]") {
  Tensor a = Tensor::from_values({1, 2, 3, 4}, {2, 2});
  Tensor b = Tensor::from_values({5, 6, 7, 8}, {2, 2});
  CHECK(matmul(a, b).to_vector() == std::vector<double>{19, 22, 43, 50});
  Tensor batch = Tensor::from_values({1, 0, 0, 1, 0, 1, 1, 0}, {2, 2, 2});  // identity and swap
  Tensor r = matmul(batch, b);
  CHECK(r.shape() == Shape{2, 2, 2});
  CHECK(r.to_vector() == std::vector<double>{5, 6, 7, 8, 7, 8, 5, 6});
  Tensor r2 = matmul(a, batch);  // a broadcast over b's batch
  CHECK(r2.to_vector() == std::vector<double>{1, 2, 3, 4, 2, 1, 4, 3});
}

TEST_CASE("matmul: large inputs agree with a reference product, forward and backward", "[ops][linalg]") {
  // Exercises the unrolled 4x4 path, the Eigen path and the split reduction of a^T g.
  for (auto dims : {std::vector<std::int64_t>{10000, 4, 4}, std::vector<std::int64_t>{40, 33, 20}}) {
    const std::int64_t n = dims[0], k = dims[1], m = dims[2];
    Tensor a = Tensor::uniform({n, k}, -1, 1, 1, DType::Float64).set_requires_grad();
    Tensor b = Tensor::uniform({k, m}, -1, 1, 2, DType::Float64).set_requires_grad();
    Tensor g = Tensor::uniform({n, m}, -1, 1, 3, DType::Float64);
    Tensor c = matmul(a, b);
    std::vector<double> ref = naive_matmul(a.detach(), b.detach()), got = c.to_vector();
    for (std::size_t i = 0; i < ref.size(); ++i) REQUIRE(got[i] == Approx(ref[i]).margin(1e-12));
    backward(c, g);
    std::vector<double> ga = naive_matmul(g, transpose(b.detach())), gb = naive_matmul(transpose(a.detach()), g);
    std::vector<double> ga_got = a.grad().to_vector(), gb_got = b.grad().to_vector();
    for (std::size_t i = 0; i < ga.size(); ++i) REQUIRE(ga_got[i] == Approx(ga[i]).margin(1e-10));
    for (std::size_t i = 0; i < gb.size(); ++i) REQUIRE(gb_got[i] == Approx(gb[i]).margin(1e-10));
  }
}

TEST_CASE("matmul: long batched reductions agree with per-batch reference products", "[ops][linalg]") {
  // b is broadcast over a's two batches, so dL/db sums both batches' a^T g.
  const std::int64_t n = 9000;
  Tensor a = Tensor::uniform({2, n, 4}, -1, 1, 4, DType::Float64).set_requires_grad();
  Tensor b = Tensor::uniform({1, 4, 3}, -1, 1, 5, DType::Float64).set_requires_grad();
  Tensor g = Tensor::uniform({2, n, 3}, -1, 1, 6, DType::Float64);
  Tensor c = matmul(a, b);
  backward(c, g);
  auto batch = [](const Tensor& t, std::int64_t i) { return reshape(slice(t.detach(), 0, i, i + 1), {t.size(1), t.size(2)}); };
  std::vector<double> gb(12, 0.0);
  for (std::int64_t i = 0; i < 2; ++i) {
    std::vector<double> part = naive_matmul(transpose(batch(a, i)), batch(g, i));
    for (std::size_t e = 0; e < gb.size(); ++e) gb[e] += part[e];
    std::vector<double> ref = naive_matmul(batch(a, i), batch(b, 0)), got = batch(c, i).to_vector();
    for (std::size_t e = 0; e < ref.size(); ++e) REQUIRE(got[e] == Approx(ref[e]).margin(1e-12));
  }
  std::vector<double> got = b.grad().to_vector();
  CHECK(b.grad().shape() == Shape{1, 4, 3});
  for (std::size_t e = 0; e < gb.size(); ++e) CHECK(got[e] == Approx(gb[e]).margin(1e-9));
}

TEST_CASE("matmul: empty operands with huge batch axes give an empty result or a MemoryError, not a huge offset table",
          "[ops][linalg]") {
  const std::int64_t huge = std::int64_t(1) << 24;
  // 2^48 batches of an empty product: nothing to multiply, and gradients are zeros.
  const Tensor a = Tensor::zeros({huge, huge, 0, 3}, DType::Float64).set_requires_grad();
  const Tensor b = Tensor::zeros({1, 1, 3, 2}, DType::Float64).set_requires_grad();
  const Tensor out = matmul(a, b);
  CHECK(out.shape() == Shape{huge, huge, 0, 2});
  backward(sum(out));
  CHECK(b.grad().shape() == b.shape());
  CHECK(b.grad().to_vector() == std::vector<double>(6, 0.0));
  // 2^40 batches of a non-empty product: refused before anything is allocated.
  const std::int64_t big = std::int64_t(1) << 20;
  CHECK_THROWS_AS(matmul(Tensor::zeros({big, big, 1, 0}), Tensor::zeros({1, 1, 0, 1})), MemoryError);
}

TEST_CASE("matmul: float32 results are bit-identical for 1 and 2 threads", "[ops][linalg][determinism]") {
  struct Case { Shape a, b; };
  for (const Case& cs : {Case{{300000, 4}, {4, 4}}, Case{{3, 20000, 4}, {3, 4, 3}}, Case{{300, 64}, {64, 48}}}) {
    auto run = [&](int threads) {
      set_num_threads(threads);
      Tensor a = Tensor::uniform(cs.a, -1, 1, 7).set_requires_grad();
      Tensor b = Tensor::uniform(cs.b, -1, 1, 8).set_requires_grad();
      Tensor c = matmul(a, b);
      backward(c, Tensor::uniform(c.shape(), -1, 1, 9));
      return std::vector<Tensor>{c.detach(), a.grad(), b.grad()};
    };
    std::vector<Tensor> one = run(1), two = run(2);
    set_num_threads(0);
    for (int i = 0; i < 3; ++i) CHECK(bit_identical(one[static_cast<std::size_t>(i)], two[static_cast<std::size_t>(i)]));
  }
}

TEST_CASE("matmul: mismatched shapes and dtypes are rejected with both shapes named", "[ops][linalg][errors]") {
  CHECK_THROWS_AS(matmul(Tensor::zeros({2, 3}), Tensor::zeros({4, 2})), ShapeError);
  CHECK_THROWS_WITH(matmul(Tensor::zeros({2, 3}), Tensor::zeros({4, 2})),
                    Catch::Contains("[2, 3]") && Catch::Contains("[4, 2]"));
  CHECK_THROWS_WITH(matmul(Tensor::zeros({2, 2, 3}), Tensor::zeros({3, 3, 2})),
                    Catch::Contains("batch") && Catch::Contains("[2, 2, 3]") && Catch::Contains("[3, 3, 2]"));
  CHECK_THROWS_AS(matmul(Tensor::zeros({3}), Tensor::zeros({3, 2})), ShapeError);
  CHECK(matmul(Tensor::zeros({2, 3}), Tensor::zeros({3, 2}, DType::Float64)).dtype() == DType::Float64);  // promoted
  CHECK_THROWS_AS(matmul(Tensor::zeros({2, 3}, DType::Int32), Tensor::zeros({3, 2}, DType::Int32)), DTypeError);
}

TEST_CASE("transpose: gradient matches finite differences", "[ops][linalg][gradcheck]") {
  require_gradcheck("transpose", [](const Inputs& in) { return transpose(in[0]); }, {random_input({2, 3, 4}, -1, 1, 21)});
}

TEST_CASE("transpose: swaps the last two axes", "[ops][linalg]") {
  Tensor a = Tensor::from_values({1, 2, 3, 4, 5, 6}, {2, 3});
  Tensor t = transpose(a);
  CHECK(t.shape() == Shape{3, 2});
  CHECK(t.to_vector() == std::vector<double>{1, 4, 2, 5, 3, 6});
  CHECK(transpose(Tensor::from_values({1, 2, 3, 4}, {1, 2, 2}, DType::Int32)).to_vector() ==
        std::vector<double>{1, 3, 2, 4});
  CHECK_THROWS_AS(transpose(Tensor::zeros({3})), ShapeError);
}

TEST_CASE("to_homogeneous: gradient matches finite differences", "[ops][linalg][gradcheck]") {
  require_gradcheck("to_homogeneous", [](const Inputs& in) { return to_homogeneous(in[0]); },
                    {random_input({5, 3}, -1, 1, 31)});
}

TEST_CASE("to_homogeneous: appends w = 1", "[ops][linalg]") {
  Tensor h = to_homogeneous(Tensor::from_values({1, 2, 3, 4, 5, 6}, {2, 3}));
  CHECK(h.shape() == Shape{2, 4});
  CHECK(h.to_vector() == std::vector<double>{1, 2, 3, 1, 4, 5, 6, 1});
  CHECK_THROWS_WITH(to_homogeneous(Tensor::zeros({2, 4})), Catch::Contains("[..., 3]") && Catch::Contains("[2, 4]"));
}

TEST_CASE("transform_points: gradient matches finite differences for points and matrix", "[ops][linalg][gradcheck]") {
  auto tp = [](const Inputs& in) { return transform_points(in[0], in[1]); };
  require_gradcheck("transform_points", tp, {random_input({6, 3}, -1, 1, 41), random_input({4, 4}, -1, 1, 42)});
  require_gradcheck("transform_points homogeneous", tp,
                    {random_input({6, 4}, -1, 1, 43), random_input({4, 4}, -1, 1, 44)});
}

TEST_CASE("transform_points: applies p' = M p with column vectors", "[ops][linalg]") {
  // Translation by (10, 20, 30) and a uniform scale of 2.
  Tensor m = Tensor::from_values({2, 0, 0, 10, 0, 2, 0, 20, 0, 0, 2, 30, 0, 0, 0, 1}, {4, 4});
  Tensor p = Tensor::from_values({1, 2, 3, 0, 0, 0}, {2, 3});
  CHECK(transform_points(p, m).to_vector() == std::vector<double>{12, 24, 36, 1, 10, 20, 30, 1});
  Tensor ph = Tensor::from_values({1, 2, 3, 0}, {1, 4});  // a direction: w = 0
  CHECK(transform_points(ph, m).to_vector() == std::vector<double>{2, 4, 6, 0});
  CHECK_THROWS_WITH(transform_points(p, Tensor::zeros({3, 3})), Catch::Contains("matrix") && Catch::Contains("[3, 3]"));
  CHECK_THROWS_WITH(transform_points(Tensor::zeros({2, 2}), m), Catch::Contains("points") && Catch::Contains("[2, 2]"));
  CHECK(transform_points(p, Tensor::zeros({4, 4}, DType::Float64)).dtype() == DType::Float64);  // promoted
}
