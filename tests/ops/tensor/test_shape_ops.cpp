// Tests of ops/tensor/shape_ops.cpp: reshape, slice, concat, stack, gather and scatter_add: finite
// difference checks, hand-computed layouts (negative indices and steps, every
// axis), duplicate indices, thread-count independence, and index validation.
#include <catch2/catch.hpp>

#include <cstring>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {
using Inputs = std::vector<Tensor>;

Tensor ints(const std::vector<double>& v, const Shape& s) { return Tensor::from_values(v, s, DType::Int32); }
Tensor iota(const Shape& s, DType dtype = DType::Float64) {
  std::vector<double> v(static_cast<std::size_t>(s.numel()));
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = double(i);
  return Tensor::from_values(v, s, dtype);
}
}  // namespace

// --- reshape -----------------------------------------------------------------

TEST_CASE("reshape: gradient matches finite differences", "[ops][shape][gradcheck]") {
  require_gradcheck("reshape", [](const Inputs& in) { return reshape(in[0], {3, -1}) * in[1]; },
                    {random_input({2, 6}, -1, 1, 1), random_input({4}, -1, 1, 2)});
}

TEST_CASE("reshape: infers a -1 extent and shares storage", "[ops][shape]") {
  Tensor a = iota({2, 3, 4});
  Tensor r = reshape(a, {-1, 4});
  CHECK(r.shape() == Shape{6, 4});
  CHECK(r.to_vector() == a.to_vector());
  CHECK(r.data<double>() == a.data<double>());
  CHECK(reshape(a, {4, -1, 3}).shape() == Shape{4, 2, 3});
  CHECK(reshape(a, {-1}).shape() == Shape{24});
  CHECK(reshape(Tensor::scalar(5), {1, 1}).shape() == Shape{1, 1});
  CHECK(reshape(ints({1, 2, 3, 4}, {4}), {2, 2}).dtype() == DType::Int32);
}

TEST_CASE("reshape: element-count mismatches and several -1 are rejected", "[ops][shape][errors]") {
  Tensor a = Tensor::zeros({2, 3});
  CHECK_THROWS_AS(reshape(a, {4, 2}), ShapeError);
  CHECK_THROWS_WITH(reshape(a, {4, 2}), Catch::Contains("[2, 3]") && Catch::Contains("[4, 2]"));
  CHECK_THROWS_AS(reshape(a, {-1, -1}), ShapeError);
  CHECK_THROWS_AS(reshape(a, {4, -1}), ShapeError);
  CHECK_THROWS_AS(reshape(a, {1, 1, 1, 2, 3}), ShapeError);
}

// --- slice -------------------------------------------------------------------

TEST_CASE("slice: gradient matches finite differences for positive and negative steps", "[ops][shape][gradcheck]") {
  Tensor a = random_input({3, 5, 2}, -1, 1, 11);
  require_gradcheck("slice", [](const Inputs& in) { return slice(in[0], 1, 1, 5, 2); }, {a});
  require_gradcheck("slice negative step", [](const Inputs& in) { return slice(in[0], -2, -1, -6, -2); }, {a});
  require_gradcheck("slice last axis", [](const Inputs& in) { return slice(in[0], -1, -1, 2); }, {a});
}

TEST_CASE("slice: negative bounds count from the end and steps follow Python", "[ops][shape]") {
  Tensor a = iota({6});
  CHECK(slice(a, 0, 1, 4).to_vector() == std::vector<double>{1, 2, 3});
  CHECK(slice(a, 0, -2, 6).to_vector() == std::vector<double>{4, 5});
  CHECK(slice(a, 0, 0, 6, 2).to_vector() == std::vector<double>{0, 2, 4});
  CHECK(slice(a, 0, -1, -7, -1).to_vector() == std::vector<double>{5, 4, 3, 2, 1, 0});  // reversed
  CHECK(slice(a, 0, 4, 0, -2).to_vector() == std::vector<double>{4, 2});
  CHECK(slice(a, 0, 2, 100).to_vector() == std::vector<double>{2, 3, 4, 5});  // clamped
  CHECK(slice(a, 0, 4, 2).numel() == 0);                                      // empty
  Tensor m = iota({2, 3});
  Tensor c = slice(m, 1, -1, -4, -1);  // columns reversed
  CHECK(c.shape() == Shape{2, 3});
  CHECK(c.to_vector() == std::vector<double>{2, 1, 0, 5, 4, 3});
  CHECK(slice(ints({1, 2, 3}, {3}), 0, 1, 3).to_vector() == std::vector<double>{2, 3});

  // The gradient lands on the picked elements only.
  Tensor x = iota({6}).set_requires_grad();
  backward(sum(slice(x, 0, 5, 0, -2)));
  CHECK(x.grad().to_vector() == std::vector<double>{0, 1, 0, 1, 0, 1});
}

TEST_CASE("slice: a zero step and a bad axis are rejected", "[ops][shape][errors]") {
  CHECK_THROWS_AS(slice(Tensor::zeros({3}), 0, 0, 3, 0), ValueError);
  CHECK_THROWS_AS(slice(Tensor::zeros({3}), 1, 0, 3), IndexError);
  CHECK_THROWS_AS(slice(Tensor::scalar(1), 0, 0, 1), ShapeError);
}

// --- concat / stack ----------------------------------------------------------

TEST_CASE("concat: gradient matches finite differences along every axis", "[ops][shape][gradcheck]") {
  Tensor a = random_input({2, 3, 2}, -1, 1, 21);
  Tensor b0 = random_input({1, 3, 2}, -1, 1, 22), b1 = random_input({2, 1, 2}, -1, 1, 23), b2 = random_input({2, 3, 3}, -1, 1, 24);
  require_gradcheck("concat", [](const Inputs& in) { return concat({in[0], in[1]}, 0); }, {a, b0});
  require_gradcheck("concat axis 1", [](const Inputs& in) { return concat({in[0], in[1], in[0]}, 1); }, {a, b1});
  require_gradcheck("concat axis -1", [](const Inputs& in) { return concat({in[1], in[0]}, -1); }, {a, b2});
}

TEST_CASE("concat: joins along an existing axis", "[ops][shape]") {
  Tensor a = Tensor::from_values({1, 2, 3, 4}, {2, 2});
  Tensor b = Tensor::from_values({5, 6}, {2, 1});
  Tensor c = concat({a, b}, 1);
  CHECK(c.shape() == Shape{2, 3});
  CHECK(c.to_vector() == std::vector<double>{1, 2, 5, 3, 4, 6});
  Tensor d = concat({a, Tensor::from_values({7, 8}, {1, 2})}, 0);
  CHECK(d.to_vector() == std::vector<double>{1, 2, 3, 4, 7, 8});
  CHECK(concat({ints({1}, {1}), ints({2, 3}, {2})}, 0).to_vector() == std::vector<double>{1, 2, 3});
  // A constant operand gets no gradient; the other gets its part of g.
  Tensor x = Tensor::from_values({1, 2}, {2, 1}, DType::Float64).set_requires_grad();
  Tensor y = Tensor::from_values({3, 4}, {2, 1}, DType::Float64);
  backward(concat({y, x}, 1), Tensor::from_values({10, 20, 30, 40}, {2, 2}, DType::Float64));
  CHECK(x.grad().to_vector() == std::vector<double>{20, 40});
}

TEST_CASE("concat: mismatched extents and dtypes are rejected", "[ops][shape][errors]") {
  CHECK_THROWS_AS(concat({Tensor::zeros({2, 2}), Tensor::zeros({3, 3})}, 0), ShapeError);
  CHECK_THROWS_WITH(concat({Tensor::zeros({2, 2}), Tensor::zeros({3, 3})}, 0),
                    Catch::Contains("[2, 2]") && Catch::Contains("[3, 3]"));
  CHECK_THROWS_AS(concat({Tensor::zeros({2}), Tensor::zeros({2, 1})}, 0), ShapeError);
  CHECK_THROWS_AS(concat({Tensor::zeros({2}), Tensor::zeros({2}, DType::Float64)}, 0), DTypeError);
  CHECK_THROWS_AS(concat({}, 0), ValueError);
  CHECK_THROWS_AS(concat({Tensor::zeros({2})}, 1), IndexError);
}

TEST_CASE("stack: gradient matches finite differences along every new axis", "[ops][shape][gradcheck]") {
  Tensor a = random_input({2, 3}, -1, 1, 31), b = random_input({2, 3}, -1, 1, 32);
  for (int axis : {0, 1, 2, -1}) {
    require_gradcheck("stack axis " + std::to_string(axis),
                      [axis](const Inputs& in) { return stack({in[0], in[1], in[0]}, axis); }, {a, b});
  }
}

TEST_CASE("stack: joins along a new axis", "[ops][shape]") {
  Tensor a = Tensor::from_values({1, 2, 3}, {3}), b = Tensor::from_values({4, 5, 6}, {3});
  Tensor s0 = stack({a, b}, 0);
  CHECK(s0.shape() == Shape{2, 3});
  CHECK(s0.to_vector() == std::vector<double>{1, 2, 3, 4, 5, 6});
  Tensor s1 = stack({a, b}, -1);
  CHECK(s1.shape() == Shape{3, 2});
  CHECK(s1.to_vector() == std::vector<double>{1, 4, 2, 5, 3, 6});
  CHECK_THROWS_WITH(stack({a, Tensor::zeros({4})}, 0), Catch::Contains("[3]") && Catch::Contains("[4]"));
  CHECK_THROWS_AS(stack({a, b}, 2), IndexError);
  CHECK_THROWS_AS(stack({Tensor::zeros({1, 1, 1, 1})}, 0), ShapeError);
}

// --- gather / scatter_add ----------------------------------------------------

TEST_CASE("gather: gradient matches finite differences with repeated indices", "[ops][shape][gradcheck]") {
  Tensor a = random_input({5, 3}, -1, 1, 41);
  Tensor idx = ints({4, 0, 4, 2, 4, 1}, {2, 3});
  require_gradcheck("gather", [idx](const Inputs& in) { return gather(in[0], idx); }, {a});
  require_gradcheck("gather rank-1", [idx](const Inputs& in) { return gather(in[0], reshape(idx, {-1})); }, {random_input({6}, -1, 1, 43)});
}

TEST_CASE("gather: picks rows, and repeated rows accumulate their gradients", "[ops][shape]") {
  Tensor a = Tensor::from_values({0, 1, 10, 11, 20, 21}, {3, 2}, DType::Float64).set_requires_grad();
  Tensor idx = ints({2, 0, 2, 2}, {4});
  Tensor r = gather(a, idx);
  CHECK(r.shape() == Shape{4, 2});
  CHECK(r.to_vector() == std::vector<double>{20, 21, 0, 1, 20, 21, 20, 21});
  backward(sum(r));
  CHECK(a.grad().to_vector() == std::vector<double>{1, 1, 0, 0, 3, 3});
  Tensor tri = ints({0, 1, 2, 2, 1, 3}, {2, 3});  // int32 data gathers too
  CHECK(gather(tri, ints({1}, {1})).to_vector() == std::vector<double>{2, 1, 3});
}

TEST_CASE("gather: out-of-range, negative and non-int32 indices are rejected", "[ops][shape][errors]") {
  Tensor a = Tensor::zeros({3, 2});
  CHECK_THROWS_AS(gather(a, ints({0, 3}, {2})), IndexError);
  CHECK_THROWS_WITH(gather(a, ints({0, 3}, {2})), Catch::Contains("gather") && Catch::Contains("3") && Catch::Contains("[3, 2]"));
  CHECK_THROWS_AS(gather(a, ints({-1}, {1})), IndexError);
  CHECK_THROWS_AS(gather(a, Tensor::zeros({2})), DTypeError);
  CHECK_THROWS_WITH(gather(a, Tensor::zeros({2})), Catch::Contains("index") && Catch::Contains("int32"));
}

TEST_CASE("scatter_add: gradient matches finite differences with duplicate indices", "[ops][shape][gradcheck]") {
  Tensor idx = ints({1, 3, 1, 0, 1}, {5});
  require_gradcheck("scatter_add", [idx](const Inputs& in) { return scatter_add(in[0], idx, 4); },
                    {random_input({5, 3}, -1, 1, 51)});
  Tensor idx2 = ints({2, 2, 0, 1, 2, 0}, {2, 3});
  require_gradcheck("scatter_add 2-d index", [idx2](const Inputs& in) { return scatter_add(in[0], idx2, 3); },
                    {random_input({2, 3, 2}, -1, 1, 52)});
}

TEST_CASE("scatter_add: duplicates accumulate and untouched rows stay zero", "[ops][shape]") {
  Tensor src = Tensor::from_values({1, 2, 3, 4, 5, 6, 7, 8}, {4, 2}, DType::Float64).set_requires_grad();
  Tensor r = scatter_add(src, ints({2, 0, 2, 2}, {4}), 4);
  CHECK(r.shape() == Shape{4, 2});
  CHECK(r.to_vector() == std::vector<double>{3, 4, 0, 0, 13, 16, 0, 0});
  backward(r, Tensor::from_values({1, 10, 2, 20, 3, 30, 4, 40}, {4, 2}, DType::Float64));
  CHECK(src.grad().to_vector() == std::vector<double>{3, 30, 1, 10, 3, 30, 3, 30});
  CHECK(scatter_add(ints({1, 1, 1}, {3}), ints({0, 1, 0}, {3}), 2).to_vector() == std::vector<double>{2, 1});
}

TEST_CASE("scatter_add: float32 results are bit-identical for 1 and 2 threads", "[ops][shape][determinism]") {
  const std::int64_t n = 400000, rows = 1000;
  Tensor src = Tensor::uniform({n, 3}, -1, 1, 61);
  std::vector<double> iv(static_cast<std::size_t>(n));
  std::uint64_t s = 12345;
  for (double& x : iv) { s = s * 6364136223846793005ULL + 1442695040888963407ULL; x = double((s >> 33) % rows); }
  Tensor idx = Tensor::from_values(iv, {n}, DType::Int32);
  set_num_threads(1);
  Tensor one = scatter_add(src, idx, rows);
  set_num_threads(2);
  Tensor two = scatter_add(src, idx, rows);
  set_num_threads(0);
  CHECK(std::memcmp(one.data<float>(), two.data<float>(), sizeof(float) * rows * 3) == 0);
  // And equal to the serial sum in ascending source order.
  std::vector<float> ref(static_cast<std::size_t>(rows * 3), 0.0f);
  const float* ps = src.data<float>();
  for (std::int64_t i = 0; i < n; ++i)
    for (int j = 0; j < 3; ++j) ref[static_cast<std::size_t>(iv[i] * 3 + j)] += ps[i * 3 + j];
  CHECK(std::memcmp(one.data<float>(), ref.data(), sizeof(float) * rows * 3) == 0);
  // gather's adjoint is the same scatter: also thread-count independent.
  auto grad_with = [&](int threads) {
    set_num_threads(threads);
    Tensor a = Tensor::uniform({rows, 3}, -1, 1, 62).set_requires_grad();
    backward(gather(a, idx), src);
    return a.grad();
  };
  Tensor g1 = grad_with(1), g2 = grad_with(2);
  set_num_threads(0);
  CHECK(std::memcmp(g1.data<float>(), g2.data<float>(), sizeof(float) * rows * 3) == 0);
}

TEST_CASE("scatter_add: bad index shapes, values and dtypes are rejected", "[ops][shape][errors]") {
  Tensor src = Tensor::zeros({4, 2});
  CHECK_THROWS_AS(scatter_add(src, ints({0, 1, 2}, {3}), 3), ShapeError);
  CHECK_THROWS_WITH(scatter_add(src, ints({0, 1, 2}, {3}), 3), Catch::Contains("[3]") && Catch::Contains("[4, 2]"));
  CHECK_THROWS_AS(scatter_add(src, ints({0, 1, 2, 3}, {4}), 3), IndexError);
  CHECK_THROWS_AS(scatter_add(src, ints({0, -1, 2, 0}, {4}), 3), IndexError);
  CHECK_THROWS_AS(scatter_add(src, Tensor::zeros({4}), 3), DTypeError);
  CHECK_THROWS_AS(scatter_add(src, ints({0, 0, 0, 0}, {4}), -1), ValueError);
}
