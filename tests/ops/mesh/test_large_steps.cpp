// LargeSteps: the matrix by hand (one triangle and an isolated vertex, shared
// edges, a degenerate face), the round trip x -> u -> x, the solve's gradient
// M^-1 g (checked by multiplying back), float64 finite differences for x and u
// on random and hard meshes, float32, smoothing of a one-vertex gradient,
// bit-identical results for 1, 2 and 8 threads, and errors naming the argument.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"
#include "ops/mesh/mesh_cases.h"

using namespace gr;
using gr::testing::bumpy_icosphere_positions;
using gr::testing::grad_input;
using gr::testing::reference_mesh;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;

namespace {

Tensor tris(const std::vector<std::int32_t>& t) { return Tensor::from_vector(t, {std::int64_t(t.size() / 3), 3}); }

}  // namespace

TEST_CASE("LargeSteps: the matrix is I + lambda (D - A), or (1 - alpha) I + alpha (D - A), of the distinct edges",
          "[ops][mesh][large_steps]") {
  const Tensor v = Tensor::uniform({4, 3}, -1, 1, 3, DType::Float64);  // vertex 3 is isolated
  const std::vector<double> L = {2, -1, -1, 0, -1, 2, -1, 0, -1, -1, 2, 0, 0, 0, 0, 0};
  const std::vector<double> m = LargeSteps(v, tris({0, 1, 2}), 3.0).matrix().to_vector();
  const std::vector<double> a = LargeSteps::with_alpha(v, tris({0, 1, 2}), 0.25).matrix().to_vector();
  for (int k = 0; k < 16; ++k) {
    CHECK(m[k] == (k % 5 == 0 ? 1.0 : 0.0) + 3 * L[k]);
    CHECK(a[k] == (k % 5 == 0 ? 0.75 : 0.0) + 0.25 * L[k]);
  }
  // An edge shared by two faces counts once, a side (3, 3) of a degenerate face not at all.
  const LargeSteps ls(v, tris({0, 1, 2, 2, 1, 3, 3, 3, 1}), 1.0);
  const Tensor M = ls.matrix();
  for (std::int64_t i = 0; i < 4; ++i) CHECK(M.at({i, i}) == std::vector<double>{3, 4, 4, 3}[i]);
  CHECK(M.at({1, 2}) == -1);
  CHECK(M.at({0, 3}) == 0);
  CHECK(ls.diagonal_weight() == 1);
  CHECK(ls.laplacian_weight() == 1);
}

TEST_CASE("LargeSteps: from_differential inverts to_differential, and its gradient is the same solve",
          "[ops][mesh][large_steps]") {
  const raster::Mesh ico = raster::make_icosphere(2);
  for (DType dtype : {DType::Float32, DType::Float64}) {
    const Tensor x = bumpy_icosphere_positions(ico, 0.1, 4, dtype);
    const LargeSteps ls(x, ico.triangles, 10.0);
    const Tensor u = ls.to_differential(x);
    const Tensor back = ls.from_differential(u);
    CHECK(u.dtype() == dtype);
    CHECK(back.dtype() == dtype);
    const double tol = dtype == DType::Float32 ? 1e-5 : 1e-12;
    CHECK(gr::testing::max_relative_difference(back.to_vector(), x.to_vector()) < tol);
    // u = M x as a dense product.
    CHECK(gr::testing::max_relative_difference(u.to_vector(), matmul(ls.matrix(), cast(x, DType::Float64)).to_vector()) <
          tol);
  }
  // dL/du = M^-1 g: M times it gives g back.
  const Tensor x = bumpy_icosphere_positions(ico, 0.1, 5);
  const LargeSteps ls(x, ico.triangles, 5.0);
  const Tensor u = ls.to_differential(x).set_requires_grad();
  const Tensor g = Tensor::uniform(x.shape(), -1, 1, 6, DType::Float64);
  backward(ls.from_differential(u), g);
  CHECK(gr::testing::max_relative_difference(matmul(ls.matrix(), u.grad()).to_vector(), g.to_vector()) < 1e-12);
}

TEST_CASE("LargeSteps: gradients of to_differential and from_differential match float64 finite differences on "
          "random and hard meshes",
          "[ops][mesh][large_steps][gradcheck]") {
  const raster::Mesh ico = raster::make_icosphere(1);
  const auto& hard = reference_mesh("hard");
  const auto& zero = reference_mesh("zero_area");
  struct Case {
    Tensor positions, triangles;
    double lambda;
    bool alpha;
  };
  const Case cases[] = {{bumpy_icosphere_positions(ico, 0.1, 1), ico.triangles, 5.0, false},
                        {hard.positions, hard.triangles, 20.0, false},
                        {zero.positions, zero.triangles, 0.9, true}};
  for (const Case& c : cases) {
    const LargeSteps ls = c.alpha ? LargeSteps::with_alpha(c.positions, c.triangles, c.lambda)
                                  : LargeSteps(c.positions, c.triangles, c.lambda);
    for (std::int64_t channels : {3, 2, 6}) {
      const Tensor x = gr::testing::random_input({c.positions.size(0), channels}, -1, 1, 10 + channels);
      require_gradcheck("LargeSteps::to_differential",
                        [&](const std::vector<Tensor>& in) { return ls.to_differential(in[0]); }, {x});
      require_gradcheck("LargeSteps::from_differential",
                        [&](const std::vector<Tensor>& in) { return ls.from_differential(in[0]); }, {x});
    }
  }
}

TEST_CASE("LargeSteps: a gradient at one vertex moves its neighbourhood", "[ops][mesh][large_steps]") {
  const raster::Mesh plane = raster::make_plane(6, 6);
  const Tensor x = cast(plane.positions, DType::Float64);
  const LargeSteps ls(x, plane.triangles, 20.0);
  const Tensor u = ls.to_differential(x).set_requires_grad();
  backward(slice(slice(ls.from_differential(u), 0, 24, 25), 1, 2, 3), Tensor::ones({1, 1}, DType::Float64));
  const Tensor step = ls.from_differential(u.detach() - u.grad()) - x;
  double largest = 0;
  for (std::int64_t i = 0; i < step.size(0); ++i) largest = std::max(largest, std::abs(step.at({i, 2})));
  int moved = 0;
  for (std::int64_t i = 0; i < step.size(0); ++i) moved += std::abs(step.at({i, 2})) > 1e-3 * largest;
  CHECK(moved > 10);
}

TEST_CASE("LargeSteps: values and gradients are bit-identical for 1, 2 and 8 threads",
          "[ops][mesh][large_steps][determinism]") {
  const raster::Mesh ico = raster::make_icosphere(5);  // 10242 vertices: the product splits into chunks
  for (DType dtype : {DType::Float32, DType::Float64}) {
    const Tensor x = bumpy_icosphere_positions(ico, 0.01, 2, dtype);
    const Tensor g = Tensor::uniform(x.shape(), -1, 1, 3, dtype);
    auto run = [&](int threads) {
      set_num_threads(threads);
      const LargeSteps ls(x, ico.triangles, 30.0);
      const Tensor xin = grad_input(x);
      const Tensor u = ls.to_differential(xin);
      const Tensor back = ls.from_differential(u);
      backward(back, g);
      set_num_threads(0);
      return std::vector<Tensor>{u, back, xin.grad()};
    };
    const auto one = run(1);
    for (int threads : {2, 8}) {
      const auto other = run(threads);
      for (std::size_t k = 0; k < one.size(); ++k) {
        INFO(dtype_name(dtype) << ", " << threads << " threads, output " << k);
        CHECK(same_bits(one[k], other[k]));
      }
    }
  }
}

TEST_CASE("LargeSteps: bad weights and values are refused naming the argument", "[ops][mesh][large_steps][errors]") {
  using Catch::Contains;
  const Tensor v = Tensor::uniform({4, 3}, -1, 1, 3);
  const Tensor f = tris({0, 1, 2, 0, 2, 3});
  CHECK_THROWS_WITH(LargeSteps(v, f, -1.0), Contains("LargeSteps: argument 'lambda' must be >= 0"));
  CHECK_THROWS_WITH(LargeSteps(v, f, std::nan("")), Contains("'lambda'"));
  CHECK_THROWS_WITH(LargeSteps(v, f, INFINITY), Contains("'lambda'"));
  CHECK_THROWS_WITH(LargeSteps::with_alpha(v, f, 1.0), Contains("LargeSteps::with_alpha: argument 'alpha' must be in [0, 1)"));
  CHECK_THROWS_WITH(LargeSteps::with_alpha(v, f, -0.1), Contains("'alpha'"));
  const LargeSteps ls(v, f, 1.0);
  CHECK_THROWS_WITH(ls.to_differential(Tensor::zeros({3, 3})),
                    Contains("LargeSteps::to_differential: argument 'x' must have shape [V, C] with V = 4"));
  CHECK_THROWS_WITH(ls.from_differential(Tensor::zeros({2, 3})),
                    Contains("LargeSteps::from_differential: argument 'u' must have shape [V, C] with V = 4"));
  CHECK_THROWS_AS(ls.from_differential(Tensor::zeros({12})), ShapeError);
  CHECK_THROWS_AS(ls.to_differential(Tensor::zeros({4, 3}, DType::Int32)), DTypeError);
  Tensor nan = Tensor::zeros({4, 2});
  nan.data<float>()[3] = std::nanf("");
  CHECK_THROWS_WITH(ls.from_differential(nan), Contains("LargeSteps::from_differential: u[3] is NaN"));
  CHECK_THROWS_AS(ls.to_differential(Tensor()), Error);
}

TEST_CASE("LargeSteps and MeshLaplacian: a mesh without faces gives M = I and L x = -x - without vertices, empty "
          "results",
          "[ops][mesh][large_steps]") {
  const Tensor v = Tensor::uniform({5, 3}, -1, 1, 8, DType::Float64);
  const Tensor none = Tensor::zeros({0, 3}, DType::Int32);
  const LargeSteps ls(v, none, 7.0);
  CHECK(same_bits(ls.to_differential(v), v));
  CHECK(same_bits(ls.from_differential(v), v));
  for (LaplacianMethod method : {LaplacianMethod::Uniform, LaplacianMethod::Cot})
    CHECK(same_bits(MeshLaplacian(v, none, method).apply(v), neg(v)));
  CHECK(MeshLaplacian(v, none, LaplacianMethod::CotCurv).apply(v).to_vector() == std::vector<double>(15, 0.0));
  const Tensor empty = Tensor::zeros({0, 3}, DType::Float64);
  const LargeSteps nothing(empty, none, 1.0);
  CHECK(nothing.from_differential(empty).shape() == Shape{0, 3});
  CHECK(nothing.to_differential(empty).shape() == Shape{0, 3});
  CHECK(MeshLaplacian(none, 0).apply(empty).shape() == Shape{0, 3});
}
