// The fused row interpreter (ops/tensor/fused_rows.h; its compiler in
// ops/tensor/fused_rows_compile.cpp) behind map_rows: every op and operand form it
// replays gives the eager graph's values and row gradients bit
// for bit, its gradients pass float64 gradchecks, and functions it cannot
// replay still run, per block.
#include <catch2/catch.hpp>

#include <atomic>
#include <functional>
#include <string>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;
using Inputs = std::vector<Tensor>;

namespace {

constexpr std::int64_t kRows = 2501, kBlock = 1000;  // a partial last block

// Deterministic values in [lo, hi).
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
  Tensor t = Tensor::from_values(v, shape, dtype);
  t.set_requires_grad();
  return t;
}

// rows: a [N, 3] with zero rows and zeros, b [N, 3] with ties against a and
// 0.25, c [N, 1] in [0.5, 1.5], d [N], e [N, 4] and f [N, 2] with zero rows;
// shared: s [3], k [] (all need gradients).
struct Case {
  Inputs rows, shared;
};

Case make_case(std::int64_t n, DType dtype) {
  std::vector<double> a = values(3 * n, -1, 1, 1), b = values(3 * n, -1, 1, 2);
  for (std::int64_t e = 0; e < 30 && e < 3 * n; ++e) a[std::size_t(e)] = 0;         // zero-length rows
  for (std::int64_t e = 30; e < 90 && e < 3 * n; ++e) b[std::size_t(e)] = a[std::size_t(e)];  // ties
  for (std::int64_t e = 90; e < 120 && e < 3 * n; ++e) b[std::size_t(e)] = 0.25;
  std::vector<double> e = values(4 * n, -1, 1, 5), f = values(2 * n, -1, 1, 6);
  for (std::int64_t k = 0; k < 8 && k < 4 * n; ++k) e[std::size_t(k)] = 0;
  for (std::int64_t k = 0; k < 4 && k < 2 * n; ++k) f[std::size_t(k)] = 0;
  return {{leaf(a, {n, 3}, dtype), leaf(b, {n, 3}, dtype), leaf(values(n, 0.5, 1.5, 3), {n, 1}, dtype),
           leaf(values(n, -1, 1, 4), {n}, dtype), leaf(e, {n, 4}, dtype), leaf(f, {n, 2}, dtype)},
          {leaf({0.3, -0.7, 2.0}, {3}, dtype), leaf({1.5}, {}, dtype)}};
}

struct Graph {
  std::string name;
  RowFunction f;
};

// Each replayed op and operand form at least once.
std::vector<Graph> replayable_graphs() {
  return {
      {"arithmetic with a shared vector, a column and a scalar",
       [](const Inputs& r, const Inputs& s) { return (r[0] - s[0]) * r[2] + r[1] / (r[2] + 2.0) - s[1] * r[1]; }},
      {"minimum and maximum with ties",
       [](const Inputs& r, const Inputs&) { return maximum(r[0], r[1]) - minimum(r[1], 0.25) + maximum(r[2], 0.0); }},
      {"neg and pow with integer, negative and fractional exponents",
       [](const Inputs& r, const Inputs&) {
         return -pow(r[0] * r[0], 0.5) + pow(r[1], 3.0) + pow(r[2] + 2.0, -2.0) * pow(r[0], 2.0) + pow(r[2], 1.7);
       }},
      {"dot and normalize on rows, with a shared vector and at zero length",
       [](const Inputs& r, const Inputs& s) {
         return normalize(r[0]) * dot(r[1], s[0]) + normalize(r[1] - s[0]) * dot(s[0], r[0]) + dot(r[0], r[1]);
       }},
      {"dot and normalize on 4-vectors and 2-vectors, at zero length",
       [](const Inputs& r, const Inputs&) {
         return normalize(r[4]) * dot(r[5], normalize(r[5] * r[2])) + dot(r[4], r[4] * r[2]) + normalize(r[4] - r[2]);
       }},
      {"rows of rank 1", [](const Inputs& r, const Inputs& s) { return r[3] * 2.0 - r[3] * s[1] + r[3] / (r[3] * r[3] + 1.0); }},
      {"a constant vector f creates",
       [](const Inputs& r, const Inputs&) {
         const Tensor dir = Tensor::from_values({0.0, 0.6, 0.8}, {3}, r[0].dtype());
         return r[0] * dir + dot(r[1], dir);
       }},
      {"a value used twice and a column subtracted",
       [](const Inputs& r, const Inputs&) { return r[2] - r[0] + r[0] * r[0] - (r[2] - r[1]); }},
      {"a column times rows with zero rows (its gradient a sum of zeros of one sign)",
       [](const Inputs& r, const Inputs&) { return r[0] * r[2]; }},
      {"clamp inside, outside and on its bounds (ties: b's 0.25s)",
       [](const Inputs& r, const Inputs&) { return clamp(r[0], -0.5, 0.5) * r[2] + clamp(r[1], 0.25, 0.75); }},
  };
}

struct Run {
  Tensor out;
  std::vector<Tensor> grads;  // rows' then shared inputs' gradients
};

// f's output and the gradients of sum(out * w) for a fixed random w.
Run run(const Case& c, const std::function<Tensor()>& f) {
  for (Tensor t : c.rows) t.zero_grad();
  for (Tensor t : c.shared) t.zero_grad();
  Run result{f(), {}};
  const Tensor w = Tensor::from_values(values(result.out.numel(), -1, 1, 9), result.out.shape(), result.out.dtype());
  backward(sum(result.out * w));
  // An input f does not use: no gradient from the eager graph, zeros from map_rows's node.
  auto grad = [](const Tensor& t) { return t.has_grad() ? t.grad() : Tensor::zeros(t.shape(), t.dtype()); };
  for (const Tensor& t : c.rows) result.grads.push_back(grad(t));
  for (const Tensor& t : c.shared) result.grads.push_back(grad(t));
  return result;
}

}  // namespace

TEST_CASE("fused map_rows gives the eager graph's values and row gradients bit for bit, for every replayed op",
          "[ops][map_rows][fused]") {
  for (DType dtype : {DType::Float32, DType::Float64}) {
    const Case c = make_case(kRows, dtype);
    for (const Graph& g : replayable_graphs()) {
      INFO(g.name << ", " << dtype_name(dtype));
      REQUIRE(map_rows_fuses(g.f, c.rows, c.shared, MapRowsOptions{kBlock}));
      const Run whole = run(c, [&] { return g.f(c.rows, c.shared); });
      const Run fused = run(c, [&] { return map_rows(g.f, c.rows, c.shared, MapRowsOptions{kBlock}); });
      const Run blocked = run(c, [&] { return map_rows(g.f, c.rows, c.shared, MapRowsOptions{kBlock, false}); });
      CHECK(same_bits(fused.out, whole.out));
      CHECK(same_bits(blocked.out, whole.out));
      for (std::size_t i = 0; i < c.rows.size(); ++i) {
        INFO("rows[" << i << "]");
        CHECK(same_bits(fused.grads[i], whole.grads[i]));
      }
      // Shared inputs' gradients: summed in another order, equal up to rounding.
      for (std::size_t j = c.rows.size(); j < whole.grads.size(); ++j) {
        const std::vector<double> a = fused.grads[j].to_vector(), b = whole.grads[j].to_vector();
        for (std::size_t e = 0; e < a.size(); ++e)
          CHECK(a[e] == Approx(b[e]).epsilon(dtype == DType::Float32 ? 1e-4 : 1e-11).margin(1e-9));
      }
    }
  }
}

using RowsOp = std::function<Tensor(const RowFunction&, const Inputs& rows, const Inputs& shared)>;

// Each replayable graph gradchecked through `op` on random rows of 150 (seed,
// seed + 1), optionally requiring that it fuses. The graphs named for ties
// have kinks (min/max, clamp's bounds) at random values, so they are skipped
// (their gradients equal the eager ops' bit for bit, above, which are gradchecked).
void gradcheck_graphs(const std::string& prefix, std::uint64_t seed, bool require_fused, const RowsOp& op) {
  const Case c = make_case(150, DType::Float64);
  const Inputs random{leaf(values(450, -1, 1, seed), {150, 3}, DType::Float64),
                      leaf(values(450, -1, 1, seed + 1), {150, 3}, DType::Float64),
                      c.rows[2],
                      c.rows[3],
                      leaf(values(600, -1, 1, seed + 2), {150, 4}, DType::Float64),
                      leaf(values(300, -1, 1, seed + 3), {150, 2}, DType::Float64),
                      c.shared[0],
                      c.shared[1]};
  auto rows_of = [](const Inputs& in) { return Inputs(in.begin(), in.begin() + 6); };
  auto shared_of = [](const Inputs& in) { return Inputs(in.begin() + 6, in.end()); };
  for (const Graph& g : replayable_graphs()) {
    if (g.name.find("ties") != std::string::npos) continue;
    if (require_fused) REQUIRE(map_rows_fuses(g.f, rows_of(random), shared_of(random), MapRowsOptions{100}));
    require_gradcheck(prefix + g.name, [&, f = g.f](const Inputs& in) { return op(f, rows_of(in), shared_of(in)); },
                      random);
  }
}

TEST_CASE("fused map_rows gradients pass float64 gradchecks", "[ops][map_rows][fused][gradcheck]") {
  gradcheck_graphs("fused ", 11, true, [](const RowFunction& f, const Inputs& r, const Inputs& s) {
    return map_rows(f, r, s, MapRowsOptions{100});
  });
}

TEST_CASE("functions with ops the interpreter does not replay run per block and give the same results",
          "[ops][map_rows][fused]") {
  const Case c = make_case(kRows, DType::Float64);
  const std::vector<Graph> others = {
      {"where", [](const Inputs& r, const Inputs&) { return where(greater(r[0], r[1]), r[0], r[1]) * r[2]; }},
      {"an op on shared inputs alone", [](const Inputs& r, const Inputs& s) { return r[0] * normalize(s[0]); }},
      {"a row-wise sum", [](const Inputs& r, const Inputs&) { return r[0] * sum(r[1], -1, true); }},
  };
  for (const Graph& g : others) {
    INFO(g.name);
    CHECK_FALSE(map_rows_fuses(g.f, c.rows, c.shared, MapRowsOptions{kBlock}));
    const Run whole = run(c, [&] { return g.f(c.rows, c.shared); });
    const Run blocked = run(c, [&] { return map_rows(g.f, c.rows, c.shared, MapRowsOptions{kBlock}); });
    CHECK(same_bits(blocked.out, whole.out));
    CHECK(same_bits(blocked.grads[0], whole.grads[0]));
  }
  // Rows so wide that a thread's lane arrays would pass 16 MiB: run per block.
  const Tensor wide = Tensor::full({100, 20000}, 0.5, DType::Float32);
  CHECK_FALSE(map_rows_fuses([](const Inputs& r, const Inputs&) { return r[0] * r[0] + 1.0; }, {wide}, {},
                             MapRowsOptions{100}));
  CHECK(map_rows_fuses([](const Inputs& r, const Inputs&) { return r[0] * r[0] + 1.0; },
                       {Tensor::full({100, 300}, 0.5, DType::Float32)}, {}, MapRowsOptions{100}));
  // Too few rows in a block to tell a constant from a value with rows: not fused.
  const Graph first = replayable_graphs().front();
  CHECK_FALSE(map_rows_fuses(first.f, c.rows, c.shared, MapRowsOptions{64}));
}

TEST_CASE("map_rows_mean gives mean(f) bit for bit, for an upstream gradient of 1 and any other",
          "[ops][map_rows][fused]") {
  // The default blocks (4096 rows here) start the loss's sum runs: one pass.
  // Blocks of 1000 rows do not: mean(map_rows(...)).
  for (std::int64_t block : {std::int64_t(0), kBlock})
  for (DType dtype : {DType::Float32, DType::Float64}) {
    const Case c = make_case(3 * 4096 + 7, dtype);
    for (const Graph& g : replayable_graphs()) {
      for (double upstream : {1.0, -2.5}) {
        INFO(g.name << ", " << dtype_name(dtype) << ", upstream " << upstream << ", block_rows " << block);
        auto grads_of = [&](const std::function<Tensor()>& loss_of) {
          for (Tensor t : c.rows) t.zero_grad();
          for (Tensor t : c.shared) t.zero_grad();
          Tensor loss = loss_of();
          backward(loss * upstream);
          std::vector<Tensor> out{loss.detach()};
          for (const Tensor& t : c.rows) out.push_back(t.has_grad() ? t.grad() : Tensor::zeros(t.shape(), t.dtype()));
          for (const Tensor& t : c.shared) out.push_back(t.has_grad() ? t.grad() : Tensor::zeros(t.shape(), t.dtype()));
          return out;
        };
        const auto whole = grads_of([&] { return mean(g.f(c.rows, c.shared)); });
        const auto fused = grads_of([&] { return map_rows_mean(g.f, c.rows, c.shared, MapRowsOptions{block}); });
        CHECK(same_bits(fused[0], whole[0]));
        for (std::size_t i = 1; i <= c.rows.size(); ++i) {
          INFO("rows[" << i - 1 << "]");
          CHECK(same_bits(fused[i], whole[i]));
        }
        for (std::size_t j = c.rows.size() + 1; j < whole.size(); ++j) {
          const std::vector<double> a = fused[j].to_vector(), b = whole[j].to_vector();
          for (std::size_t e = 0; e < a.size(); ++e)
            CHECK(a[e] == Approx(b[e]).epsilon(dtype == DType::Float32 ? 1e-4 : 1e-11).margin(1e-9));
        }
      }
    }
  }
  // Without gradients, and for a function it does not fuse: still mean(f).
  const Case c = make_case(kRows, DType::Float64);
  auto where_rows = [](const Inputs& r, const Inputs&) { return where(greater(r[0], r[1]), r[0], r[1]); };
  CHECK(same_bits(map_rows_mean(where_rows, c.rows, c.shared),
                  mean(where(greater(c.rows[0], c.rows[1]), c.rows[0], c.rows[1]))));
  NoGradGuard no_grad;
  const Graph first = replayable_graphs().front();
  CHECK(same_bits(map_rows_mean(first.f, c.rows, c.shared, MapRowsOptions{kBlock}), mean(first.f(c.rows, c.shared))));
}

TEST_CASE("map_rows_mean gradients pass a float64 gradcheck", "[ops][map_rows][fused][gradcheck]") {
  gradcheck_graphs("map_rows_mean ", 13, false, [](const RowFunction& f, const Inputs& r, const Inputs& s) {
    return map_rows_mean(f, r, s, MapRowsOptions{100});
  });
}

TEST_CASE("map_rows_mean in one pass (default blocks) gives shared inputs gradients that pass a float64 gradcheck",
          "[ops][map_rows][fused][gradcheck]") {
  // Blocks of 4096 rows start the loss's 4096-element sum runs (rows of 1 or
  // 3 outputs), so the gradients come with the values, in one pass; two whole
  // blocks and a partial one. A gradcheck perturbs every element, so only the
  // shared inputs require gradients here; the rows are constants.
  const std::int64_t n = 2 * 4096 + 100;
  const Inputs rows{Tensor::from_values(values(3 * n, -1, 1, 21), {n, 3}, DType::Float64),
                    Tensor::from_values(values(3 * n, -1, 1, 22), {n, 3}, DType::Float64),
                    Tensor::from_values(values(n, 0.5, 1.5, 23), {n, 1}, DType::Float64),
                    Tensor::from_values(values(n, -1, 1, 24), {n}, DType::Float64)};
  const Inputs shared{leaf({0.3, -0.7, 2.0}, {3}, DType::Float64), leaf({1.5}, {}, DType::Float64)};
  int checked = 0;
  for (const Graph& g : replayable_graphs()) {
    if (g.name.find("shared") == std::string::npos && g.name.find("rank 1") == std::string::npos) continue;
    REQUIRE(map_rows_fuses(g.f, rows, shared));
    require_gradcheck("map_rows_mean one pass " + g.name,
                      [f = g.f, &rows](const Inputs& in) { return map_rows_mean(f, rows, in); }, shared);
    ++checked;
  }
  CHECK(checked == 3);
}

TEST_CASE("fused map_rows on images: rows of pixels give the eager graph's bits, and gradients pass a gradcheck",
          "[ops][map_rows][fused][gradcheck]") {
  // An image's [H, W, C] rows: the interpreter's lanes are its pixels.
  auto image_graph = [](const Inputs& r, const Inputs& s) {
    Tensor l = normalize(s[0] - r[0]);
    return r[2] * maximum(dot(r[1], l), 0.0) + pow(r[1] - s[1] * r[0], 2.0) / (r[2] + 1.0);
  };
  for (DType dtype : {DType::Float32, DType::Float64}) {
    const std::int64_t H = 40, W = 50;
    const Case flat = make_case(H * W, dtype);
    const Case c{{leaf(flat.rows[0].to_vector(), {H, W, 3}, dtype), leaf(flat.rows[1].to_vector(), {H, W, 3}, dtype),
                  leaf(flat.rows[2].to_vector(), {H, W, 1}, dtype)},
                 flat.shared};
    INFO(dtype_name(dtype));
    REQUIRE(map_rows_fuses(image_graph, c.rows, c.shared, MapRowsOptions{7}));  // 7 image rows of 50 pixels
    const Run whole = run(c, [&] { return image_graph(c.rows, c.shared); });
    const Run fused = run(c, [&] { return map_rows(image_graph, c.rows, c.shared, MapRowsOptions{7}); });
    CHECK(same_bits(fused.out, whole.out));
    for (std::size_t i = 0; i < c.rows.size(); ++i) CHECK(same_bits(fused.grads[i], whole.grads[i]));
    for (Tensor t : c.rows) t.zero_grad();
    backward(map_rows_mean(image_graph, c.rows, c.shared, MapRowsOptions{7}));
    const Tensor mean_grad = c.rows[1].grad();
    for (Tensor t : c.rows) t.zero_grad();
    backward(mean(image_graph(c.rows, c.shared)));
    CHECK(same_bits(mean_grad, c.rows[1].grad()));
  }
  const Case small = make_case(6 * 20, DType::Float64);
  const Inputs in{leaf(values(360, -1, 1, 15), {6, 20, 3}, DType::Float64),
                  leaf(values(360, -1, 1, 16), {6, 20, 3}, DType::Float64),
                  leaf(values(120, 0.5, 1.5, 17), {6, 20, 1}, DType::Float64), small.shared[0], small.shared[1]};
  REQUIRE(map_rows_fuses(image_graph, {in[0], in[1], in[2]}, {in[3], in[4]}, MapRowsOptions{4}));
  require_gradcheck("fused image rows",
                    [&](const Inputs& x) {
                      return map_rows(image_graph, {x[0], x[1], x[2]}, {x[3], x[4]}, MapRowsOptions{4});
                    },
                    in);
}

TEST_CASE("map_rows picks about 4096 pixels per block by default", "[ops][map_rows][fused]") {
  // Unfused, f runs on every block: the most rows it sees at once is the block size.
  auto block_size = [](const Tensor& rows) {
    std::atomic<std::int64_t> most{0};
    map_rows([&](const Inputs& r, const Inputs&) {
      std::int64_t seen = most.load();
      while (r[0].size(0) > seen && !most.compare_exchange_weak(seen, r[0].size(0))) {}
      return r[0] * 2.0;
    }, {rows}, {}, MapRowsOptions{0, false});
    return most.load();
  };
  CHECK(block_size(Tensor::full({10000, 3}, 1.0)) == 4096);
  CHECK(block_size(Tensor::full({1000, 3}, 1.0)) == 1000);
  CHECK(block_size(Tensor::full({50, 100, 3}, 1.0)) == 40);  // an image 100 pixels wide: 40 rows
  CHECK(block_size(Tensor::full({3, 5000, 3}, 1.0)) == 1);   // wider than 4096 pixels: one row
}

TEST_CASE("map_rows traces f on its first 256 pixels and replays the rest, block 0 included",
          "[ops][map_rows][fused]") {
  // Fused, f runs once: on the trace block, the first rows holding 256 pixels.
  auto calls = [](const Tensor& rows, std::int64_t* first_rows) {
    std::atomic<int> count{0};
    std::atomic<std::int64_t> first{-1};
    const Tensor out = map_rows([&](const Inputs& r, const Inputs&) {
      ++count;
      std::int64_t none = -1;
      first.compare_exchange_strong(none, r[0].size(0));
      return r[0] * 2.0 + 1.0;
    }, {rows});
    CHECK(same_bits(out, rows * 2.0 + 1.0));
    *first_rows = first.load();
    return count.load();
  };
  std::int64_t first = 0;
  CHECK(calls(Tensor::uniform({10000, 3}, -1, 1, 3), &first) == 1);
  CHECK(first == 256);
  CHECK(calls(Tensor::uniform({50, 100, 3}, -1, 1, 4), &first) == 1);
  CHECK(first == 3);  // 300 pixels
  CHECK(calls(Tensor::uniform({200, 3}, -1, 1, 5), &first) == 1);
  CHECK(first == 200);  // all of it
}
