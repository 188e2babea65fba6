// map_rows (ops/tensor/map_rows.h): blocked, checkpointed evaluation of a row-wise
// function gives the whole-input graph's values and gradients, the same bits
// for any thread count, and clear errors for functions that are not row-wise.
#include <catch2/catch.hpp>

#include "../bench/shading_graph.h"
#include "autodiff/base/storage.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;
using Inputs = std::vector<Tensor>;

namespace {

// Blinn-Phong colour of bench/shading_graph.h, row-wise: rows {p, n, albedo}, shared {light, cam}.
Tensor blinn_phong_rows(const Inputs& r, const Inputs& s) {
  Tensor l = normalize(s[0] - r[0]);
  Tensor v = normalize(s[1] - r[0]);
  Tensor h = normalize(l + v);
  return r[2] * maximum(dot(r[1], l), 0.0) + 0.5 * pow(maximum(dot(r[1], h), 0.0), 32.0);
}

}  // namespace

TEST_CASE("map_rows: blocked Blinn-Phong equals the whole graph bit for bit in values and row gradients",
          "[ops][map_rows]") {
  for (DType dtype : {DType::Float32, DType::Float64}) {
    auto scene = bench::make_shading_scene(10007, dtype);  // a partial last block
    Tensor whole = blinn_phong_rows({scene.p, scene.n, scene.albedo}, {scene.light, scene.cam});
    backward(mean(pow(whole - scene.target, 2.0)));
    const Tensor gn = scene.n.grad(), ga = scene.albedo.grad(), gl = scene.light.grad();
    scene.n.zero_grad();
    scene.albedo.zero_grad();
    scene.light.zero_grad();

    Tensor blocked = map_rows(blinn_phong_rows, {scene.p, scene.n, scene.albedo}, {scene.light, scene.cam},
                              MapRowsOptions{1000});
    CHECK(same_bits(blocked, whole));
    backward(mean(pow(blocked - scene.target, 2.0)));
    CHECK(same_bits(scene.n.grad(), gn));
    CHECK(same_bits(scene.albedo.grad(), ga));
    // The light's gradient is summed per block, then over blocks: equal up to rounding.
    const std::vector<double> a = scene.light.grad().to_vector(), b = gl.to_vector();
    for (int k = 0; k < 3; ++k) CHECK(a[k] == Approx(b[k]).epsilon(dtype == DType::Float32 ? 1e-4 : 1e-12));
    CHECK_FALSE(scene.p.has_grad());  // p does not require a gradient
  }
}

TEST_CASE("map_rows: gradients of row and shared inputs pass a float64 gradcheck", "[ops][map_rows][gradcheck]") {
  Tensor x = random_input({23, 3}, -1, 1, 1), w = random_input({23, 2}, 0.5, 2, 2), c = random_input({3}, -1, 1, 3);
  auto f = [](const Inputs& in) {
    return map_rows(
        [](const Inputs& r, const Inputs& s) {
          Tensor d = normalize(r[0] - s[0]);  // broadcast of a shared [3] against [rows, 3]
          return concat({d * sum(r[1], -1, true), exp(r[1])}, 1);
        },
        {in[0], in[1]}, {in[2]}, MapRowsOptions{5});
  };
  require_gradcheck("map_rows random", f, {x, w, c});
  // Hard case: one block holding everything, and blocks of one row.
  for (std::int64_t block : {1, 23, 100}) {
    auto g = [block](const Inputs& in) {
      return map_rows([](const Inputs& r, const Inputs& s) { return r[0] * s[0]; }, {in[0]}, {in[1]},
                      MapRowsOptions{block});
    };
    require_gradcheck("map_rows block " + std::to_string(block), g, {x, c});
  }
}

TEST_CASE("map_rows and map_rows_mean: values and gradients are bit-identical for 1 2 and 8 threads",
          "[ops][map_rows][determinism]") {
  auto scene = bench::make_shading_scene(30000, DType::Float32);
  auto run = [&](int threads) {
    set_num_threads(threads);
    Tensor out = map_rows(blinn_phong_rows, {scene.p, scene.n, scene.albedo}, {scene.light, scene.cam},
                          MapRowsOptions{512});
    backward(mean(pow(out - scene.target, 2.0)));
    std::vector<Tensor> result{out.detach(), scene.n.grad(), scene.albedo.grad(), scene.light.grad()};
    scene.n.zero_grad();
    scene.albedo.zero_grad();
    scene.light.zero_grad();
    Tensor loss = map_rows_mean(bench::blinn_phong_squared_error, {scene.p, scene.n, scene.albedo, scene.target},
                                {scene.light, scene.cam}, MapRowsOptions{512});
    backward(loss);
    for (const Tensor& t : {loss.detach(), scene.n.grad(), scene.albedo.grad(), scene.light.grad()}) result.push_back(t);
    scene.n.zero_grad();
    scene.albedo.zero_grad();
    scene.light.zero_grad();
    return result;
  };
  const std::vector<Tensor> one = run(1);
  for (int threads : {2, 8}) {
    const std::vector<Tensor> other = run(threads);
    for (std::size_t i = 0; i < one.size(); ++i) CHECK(same_bits(other[i], one[i]));
  }
  set_num_threads(0);
}

TEST_CASE("map_rows: a function that is not row-wise or inputs of different lengths are refused by name",
          "[ops][map_rows][errors]") {
  Tensor a = random_input({10, 3}, -1, 1, 4), b = random_input({9, 3}, -1, 1, 5);
  auto identity = [](const Inputs& r, const Inputs&) { return r[0]; };
  CHECK_THROWS_WITH(map_rows(identity, {a, b}), Catch::Contains("rows[1] has 9 rows"));
  CHECK_THROWS_WITH(map_rows([](const Inputs& r, const Inputs&) { return sum(r[0], 0, true); }, {a}, {},
                             MapRowsOptions{4}),
                    Catch::Contains("one row per input row"));
  CHECK_THROWS_WITH(map_rows(identity, {a}, {}, MapRowsOptions{-1}), Catch::Contains("block_rows must be at least 1"));
  CHECK_THROWS_AS(map_rows(identity, {}), ValueError);
  CHECK_THROWS_AS(map_rows(RowFunction(), {a}), ValueError);
  // A recorded tensor captured by f (not passed as an input) is refused: its
  // gradient could not reach it.
  Tensor captured = random_input({3}, -1, 1, 8) * 2.0;
  CHECK_THROWS_WITH(map_rows([&](const Inputs& r, const Inputs&) { return r[0] + captured; }, {a}, {}, MapRowsOptions{4}),
                    Catch::Contains("f used a recorded tensor it captured"));
  Tape::current().clear();
}

TEST_CASE("map_rows: blocked evaluation holds less memory at its peak than the whole graph", "[ops][map_rows]") {
  auto scene = bench::make_shading_scene(200000, DType::Float32);
  // The loss's per-pixel part inside the block too: only the [N, 3] squared
  // errors, their gradient and the parameters' gradients are whole-image tensors.
  auto squared_error = [](const Inputs& r, const Inputs& s) {
    return pow(blinn_phong_rows({r[0], r[1], r[2]}, s) - r[3], 2.0);
  };
  auto peak_of = [&](bool blocked) {
    reset_storage_peak();
    const std::int64_t base = storage_stats().live_bytes;
    const Inputs rows{scene.p, scene.n, scene.albedo, scene.target}, shared{scene.light, scene.cam};
    backward(mean(blocked ? map_rows(squared_error, rows, shared) : squared_error(rows, shared)));
    scene.n.zero_grad();
    scene.albedo.zero_grad();
    scene.light.zero_grad();
    return storage_stats().peak_live_bytes - base;
  };
  const std::int64_t whole = peak_of(false), blocked = peak_of(true);
  INFO("peak bytes: whole graph " << whole << ", blocked " << blocked);
  CHECK(blocked * 3 < whole * 2);  // measured: about half
}

TEST_CASE("map_rows: no rows gives an empty output and empty gradients", "[ops][map_rows]") {
  Tensor a = random_input({0, 3}, -1, 1, 6), c = random_input({3}, -1, 1, 7);
  Tensor out = map_rows([](const Inputs& r, const Inputs& s) { return r[0] * s[0]; }, {a}, {c});
  CHECK(out.shape() == Shape({0, 3}));
  backward(sum(out));
  CHECK(a.grad().shape() == Shape({0, 3}));
}
