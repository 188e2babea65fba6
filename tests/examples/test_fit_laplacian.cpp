// The fit's uniform Laplacian, one recorded sparse op: the same bits as the
// gather + scatter_add composite it replaced (forward, gradient, and through
// the fit's smoothing passes), float64 finite differences on a random mesh and
// on a mesh with a one-neighbour and an isolated vertex, and the same bits for
// any thread count.
#include <catch2/catch.hpp>

#include <functional>
#include <set>
#include <utility>
#include <vector>

#include "autodiff/parallel.h"
#include "examples/fit/geometry.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"

using namespace gr;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;

namespace {

// L(p) = p - scatter_add(gather(p, to), from, N) * (1/deg), as the fit wrote it
// before the op existed: every undirected edge once, in both directions.
struct CompositeLaplacian {
  Tensor from, to, inv_degree;
  std::int64_t n;
  CompositeLaplacian(const Tensor& triangles, std::int64_t num_vertices) : n(num_vertices) {
    std::set<std::pair<std::int32_t, std::int32_t>> edges;
    const std::int32_t* t = triangles.data<std::int32_t>();
    for (std::int64_t k = 0; k < triangles.numel(); k += 3)
      for (int c = 0; c < 3; ++c) {
        std::int32_t a = t[k + c], b = t[k + (c + 1) % 3];
        if (a > b) std::swap(a, b);
        if (a != b) edges.insert({a, b});
      }
    std::vector<std::int32_t> f, o;
    std::vector<double> degree(static_cast<std::size_t>(n), 0.0);
    for (const auto& [a, b] : edges) {
      f.insert(f.end(), {a, b});
      o.insert(o.end(), {b, a});
      degree[a] += 1, degree[b] += 1;
    }
    for (double& d : degree) d = d > 0 ? 1.0 / d : 0.0;
    from = Tensor::from_vector(f, {std::int64_t(f.size())});
    to = Tensor::from_vector(o, {std::int64_t(o.size())});
    inv_degree = Tensor::from_values(degree, {n, 1});
  }
  Tensor apply(const Tensor& p) const { return p - scatter_add(gather(p, to), from, n) * cast(inv_degree, p.dtype()); }
};

// An icosphere with its points moved at random (no symmetry hides an index mix-up).
Tensor bumpy_positions(const raster::Mesh& mesh, std::uint64_t seed, DType dtype) {
  NoGradGuard no_grad;
  return (cast(mesh.positions, dtype) + Tensor::uniform({mesh.num_vertices(), 3}, -0.1, 0.1, seed, dtype)).copy();
}

// Triangle 0-1-2, a degenerate 3-3-4 (vertices 3 and 4 have one neighbour
// each), and vertex 5 in no triangle.
Tensor hard_triangles() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 3, 4}, {2, 3}); }

// L(x) and, through the fit's smoothing x <- x - L(x) / 2 twice plus the
// penalty's L, the gradient of a fixed weighting of the result.
std::pair<Tensor, Tensor> value_and_gradient(const std::function<Tensor(const Tensor&)>& L, const Tensor& p) {
  const Tensor x0 = p.detach().copy().set_requires_grad();
  Tensor x = x0;
  for (int k = 0; k < 2; ++k) x = x - 0.5 * L(x);
  const Tensor l = L(x);
  backward(sum(l * l) + sum(x * Tensor::uniform(x.shape(), -1, 1, 77, x.dtype())));
  NoGradGuard no_grad;
  return {L(p), x0.grad()};
}

}  // namespace

TEST_CASE("fit example: the uniform Laplacian op has the bits of the gather + scatter_add composite, value and "
          "gradient, in float32 and float64",
          "[examples][fit]") {
  for (int subdivisions : {1, 5}) {  // 42 points inline, 10242 points in parallel chunks
    const raster::Mesh mesh = raster::make_icosphere(subdivisions);
    const fit::UniformLaplacian op(mesh.triangles, mesh.num_vertices());
    const CompositeLaplacian composite(mesh.triangles, mesh.num_vertices());
    for (DType dtype : {DType::Float32, DType::Float64}) {
      INFO("icosphere(" << subdivisions << "), " << dtype_name(dtype));
      const Tensor p = bumpy_positions(mesh, 3, dtype);
      const auto [value, gradient] = value_and_gradient([&](const Tensor& x) { return op.apply(x); }, p);
      const auto [value_ref, gradient_ref] = value_and_gradient([&](const Tensor& x) { return composite.apply(x); }, p);
      CHECK(same_bits(value, value_ref));
      CHECK(same_bits(gradient, gradient_ref));
    }
  }
  // And on the hard mesh: one-neighbour vertices and an isolated one (L(p)_5 = p_5).
  const fit::UniformLaplacian op(hard_triangles(), 6);
  const CompositeLaplacian composite(hard_triangles(), 6);
  const Tensor p = Tensor::uniform({6, 3}, -1, 1, 4);
  const auto [value, gradient] = value_and_gradient([&](const Tensor& x) { return op.apply(x); }, p);
  const auto [value_ref, gradient_ref] = value_and_gradient([&](const Tensor& x) { return composite.apply(x); }, p);
  CHECK(same_bits(value, value_ref));
  CHECK(same_bits(gradient, gradient_ref));
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(value.at({5, c}) == p.at({5, c}));
    CHECK(value.at({3, c}) == float(p.at({3, c}) - p.at({4, c})));
  }
}

TEST_CASE("fit example: the uniform Laplacian's gradient matches float64 finite differences on a random mesh and "
          "with one-neighbour and isolated vertices",
          "[examples][fit][gradcheck]") {
  const raster::Mesh mesh = raster::make_icosphere(1);
  const fit::UniformLaplacian laplacian(mesh.triangles, mesh.num_vertices());
  const Tensor p = bumpy_positions(mesh, 5, DType::Float64).set_requires_grad();
  require_gradcheck("uniform laplacian", [&](const std::vector<Tensor>& in) { return laplacian.apply(in[0]); }, {p});
  require_gradcheck(
      "uniform laplacian penalty", [&](const std::vector<Tensor>& in) { return laplacian.penalty(in[0]); }, {p});
  const fit::UniformLaplacian hard(hard_triangles(), 6);
  const Tensor q = gr::testing::random_input({6, 2}, -1, 1, 6);  // any channel count
  require_gradcheck("uniform laplacian, hard mesh", [&](const std::vector<Tensor>& in) { return hard.apply(in[0]); },
                    {q});
}

TEST_CASE("fit example: the uniform Laplacian's value and gradient are bit-identical for 1, 2 and 8 threads",
          "[examples][fit][determinism]") {
  const raster::Mesh mesh = raster::make_icosphere(5);  // 10242 points: several chunks
  const fit::UniformLaplacian op(mesh.triangles, mesh.num_vertices());
  const Tensor p = bumpy_positions(mesh, 8, DType::Float32);
  auto run = [&](int threads) {
    set_num_threads(threads);
    auto result = value_and_gradient([&](const Tensor& x) { return op.apply(x); }, p);
    set_num_threads(0);
    return result;
  };
  const auto [value, gradient] = run(1);
  for (int threads : {2, 8}) {
    INFO(threads << " threads");
    const auto [v, g] = run(threads);
    CHECK(same_bits(value, v));
    CHECK(same_bits(gradient, g));
  }
}

TEST_CASE("fit example: the uniform Laplacian rejects positions of the wrong shape and out-of-range triangles",
          "[examples][fit][errors]") {
  const fit::UniformLaplacian op(hard_triangles(), 6);
  CHECK_THROWS_AS(op.apply(Tensor::zeros({5, 3})), ShapeError);
  CHECK_THROWS_AS(op.apply(Tensor::zeros({18})), ShapeError);
  CHECK_THROWS_AS(op.apply(Tensor::zeros({6, 3}, DType::Int32)), DTypeError);
  CHECK_THROWS_AS(fit::UniformLaplacian(hard_triangles(), 4), IndexError);  // index 4
  CHECK_THROWS_AS(fit::UniformLaplacian(Tensor::zeros({2, 3}), 6), ShapeError);
}
