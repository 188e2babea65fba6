// MeshLaplacian: the uniform operator has the bits of a gather + scatter_add
// composite (value and gradient, also through the fit example's smoothing
// passes), the cotangent operators match a loop over their definitions with
// cotangents taken as cos / sin of the corner angles, gradients match float64
// finite differences on random and hard meshes, results are bit-identical for
// 1, 2 and 8 threads, and bad input is refused naming the argument; and the
// same for smooth, which has the bits of its passes as a composite.
#include <catch2/catch.hpp>

#include <climits>
#include <cmath>
#include <cstdint>
#include <functional>
#include <set>
#include <utility>
#include <vector>

#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "raster/procedural.h"
#include "test_support.h"
#include "ops/mesh/mesh_cases.h"

using namespace gr;
using gr::testing::bumpy_icosphere_positions;
using gr::testing::check_same_bits_for_any_thread_count;
using gr::testing::grad_input;
using gr::testing::reference_mesh;
using gr::testing::require_gradcheck;
using gr::testing::same_bits;

namespace {

constexpr LaplacianMethod kMethods[] = {LaplacianMethod::Uniform, LaplacianMethod::Cot, LaplacianMethod::CotCurv};

// L(p) = scatter_add(gather(p, to), from, N) * (1/deg) - p: every distinct
// undirected edge once in each direction (an edge (i, i) twice from i to i).
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
        edges.insert({a, b});
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
    inv_degree = Tensor::from_values(degree, {n, 1}, DType::Float64);
  }
  Tensor apply(const Tensor& p) const { return scatter_add(gather(p, to), from, n) * cast(inv_degree, p.dtype()) - p; }
};

// Triangle 0-1-2, a degenerate 3-3-4 (vertex 4's only neighbour is 3; the side
// (3, 3) is an edge), and vertex 5 in no triangle.
Tensor hard_triangles() { return Tensor::from_vector<std::int32_t>({0, 1, 2, 3, 3, 4}, {2, 3}); }

// L(x) and, through the fit's smoothing x <- x + L(x) / 2 twice plus a squared
// penalty, the gradient of a fixed weighting of the result.
std::pair<Tensor, Tensor> value_and_gradient(const std::function<Tensor(const Tensor&)>& L, const Tensor& p) {
  const Tensor x0 = p.detach().copy().set_requires_grad();
  Tensor x = x0;
  for (int k = 0; k < 2; ++k) x = x + 0.5 * L(x);
  const Tensor l = L(x);
  backward(sum(l * l) + sum(x * Tensor::uniform(x.shape(), -1, 1, 77, x.dtype())));
  NoGradGuard no_grad;
  return {L(p), x0.grad()};
}

// The definition, looped (float64): cot of each corner as cos / sin from its
// two side vectors, w_ij summed over the faces' sides, the row scale of the method.
std::vector<double> definition(const Tensor& positions, const Tensor& triangles, LaplacianMethod method,
                               const std::vector<double>& x, std::int64_t C) {
  const std::int64_t V = positions.size(0);
  auto p = [&](std::int64_t i, int k) { return positions.at({i, k}); };
  std::vector<std::vector<std::pair<std::int64_t, double>>> w(static_cast<std::size_t>(V));
  std::vector<double> area(static_cast<std::size_t>(V), 0.0);
  for (std::int64_t f = 0; f < triangles.size(0); ++f) {
    std::int64_t c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::int64_t(triangles.at({f, k}));
    for (int k = 0; k < 3; ++k) {
      double u[3], v[3];
      for (int d = 0; d < 3; ++d) u[d] = p(c[(k + 1) % 3], d) - p(c[k], d), v[d] = p(c[(k + 2) % 3], d) - p(c[k], d);
      const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      const double sin2a = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);  // twice the area
      const double cot = (u[0] * v[0] + u[1] * v[1] + u[2] * v[2]) / sin2a;
      const std::int64_t i = c[(k + 1) % 3], j = c[(k + 2) % 3];
      w[i].push_back({j, cot});
      w[j].push_back({i, cot});
      area[c[k]] += 0.5 * sin2a;
    }
  }
  std::vector<double> r(static_cast<std::size_t>(V * C));
  for (std::int64_t i = 0; i < V; ++i) {
    double total = 0;
    for (const auto& [j, wij] : w[i]) total += wij;
    for (std::int64_t c = 0; c < C; ++c) {
      double s = 0;
      for (const auto& [j, wij] : w[i]) s += wij * x[j * C + c];
      const double xi = x[i * C + c];
      if (method == LaplacianMethod::Cot) r[i * C + c] = total > 0 ? s / total - xi : s * total - xi;
      else r[i * C + c] = area[i] > 0 ? (s - total * xi) / (4 * area[i]) : 0.0;
    }
  }
  return r;
}

}  // namespace

TEST_CASE("MeshLaplacian: the uniform operator has the bits of the gather + scatter_add composite, value and "
          "gradient, in float32 and float64",
          "[ops][mesh][laplacian]") {
  for (int subdivisions : {1, 5}) {  // 42 points inline, 10242 points in parallel chunks
    const raster::Mesh mesh = raster::make_icosphere(subdivisions);
    const MeshLaplacian op(mesh.triangles, mesh.num_vertices());
    const CompositeLaplacian composite(mesh.triangles, mesh.num_vertices());
    for (DType dtype : {DType::Float32, DType::Float64}) {
      INFO("icosphere(" << subdivisions << "), " << dtype_name(dtype));
      const Tensor p = bumpy_icosphere_positions(mesh, 0.1, 3, dtype);
      const auto [value, gradient] = value_and_gradient([&](const Tensor& x) { return op.apply(x); }, p);
      const auto [value_ref, gradient_ref] = value_and_gradient([&](const Tensor& x) { return composite.apply(x); }, p);
      CHECK(same_bits(value, value_ref));
      CHECK(same_bits(gradient, gradient_ref));
    }
  }
  // And on the hard mesh: r_4 = p_3 - p_4 (one neighbour), r_3 = (2 p_3 + p_4) / 3 - p_3
  // (the side (3, 3) lists 3 twice, as PyTorch3D), and r_5 = -p_5 (isolated).
  const MeshLaplacian op(hard_triangles(), 6);
  const CompositeLaplacian composite(hard_triangles(), 6);
  const Tensor p = Tensor::uniform({6, 3}, -1, 1, 4, DType::Float64);
  const auto [value, gradient] = value_and_gradient([&](const Tensor& x) { return op.apply(x); }, p);
  const auto [value_ref, gradient_ref] = value_and_gradient([&](const Tensor& x) { return composite.apply(x); }, p);
  CHECK(same_bits(value, value_ref));
  CHECK(same_bits(gradient, gradient_ref));
  for (std::int64_t c = 0; c < 3; ++c) {
    CHECK(value.at({5, c}) == -p.at({5, c}));
    CHECK(value.at({4, c}) == p.at({3, c}) - p.at({4, c}));
    CHECK(value.at({3, c}) == Approx((2 * p.at({3, c}) + p.at({4, c})) / 3 - p.at({3, c})).epsilon(1e-14));
  }
}

TEST_CASE("MeshLaplacian: the cot and cotcurv operators match a loop over their definitions with cotangents as "
          "cos / sin",
          "[ops][mesh][laplacian]") {
  // The hard reference mesh (a hole, an isolated vertex, a sliver, a fin) without its
  // degenerate face (a, w, w), whose corner angles cos / sin cannot give.
  const auto& hard = reference_mesh("hard");
  std::vector<std::int32_t> kept;
  for (std::int64_t f = 0; f < hard.triangles.size(0); ++f) {
    const auto a = hard.triangles.at({f, 0}), b = hard.triangles.at({f, 1}), c = hard.triangles.at({f, 2});
    if (a != b && b != c && a != c) kept.insert(kept.end(), {std::int32_t(a), std::int32_t(b), std::int32_t(c)});
  }
  REQUIRE(std::int64_t(kept.size()) == 3 * hard.triangles.size(0) - 3);
  const raster::Mesh mesh = raster::make_icosphere(2);
  const std::pair<Tensor, Tensor> cases[] = {
      {bumpy_icosphere_positions(mesh, 0.08, 21), mesh.triangles},
      {hard.positions, Tensor::from_vector(kept, {std::int64_t(kept.size() / 3), 3})}};
  for (const auto& [positions, triangles] : cases) {
    for (LaplacianMethod method : {LaplacianMethod::Cot, LaplacianMethod::CotCurv}) {
      INFO(laplacian_method_name(method) << ", " << positions.size(0) << " vertices");
      const std::int64_t C = 2;
      const Tensor x = Tensor::uniform({positions.size(0), C}, -1, 1, 5, DType::Float64);
      const MeshLaplacian op(positions, triangles, method);
      const std::vector<double> want = definition(positions, triangles, method, x.to_vector(), C);
      const std::vector<double> got = op.apply(x).to_vector();
      // The hard mesh's sliver and degenerate faces have cotangents near 1e6: compare to the largest |r|.
      double scale = 0;
      for (double r : want) scale = std::max(scale, std::abs(r));
      for (std::size_t k = 0; k < want.size(); ++k) CHECK(got[k] == Approx(want[k]).margin(1e-9 * scale));
      // to_dense is the same map.
      const std::vector<double> dense = matmul(op.to_dense(), x).to_vector();
      for (std::size_t k = 0; k < want.size(); ++k) CHECK(dense[k] == Approx(got[k]).margin(1e-12 * scale));
    }
  }
}

TEST_CASE("MeshLaplacian: gradients match float64 finite differences for every method, on random meshes and on "
          "one with a hole, an isolated vertex, a degenerate face, a sliver and a fin",
          "[ops][mesh][laplacian][gradcheck]") {
  const raster::Mesh mesh = raster::make_icosphere(1);
  const auto& hard = reference_mesh("hard");
  for (LaplacianMethod method : kMethods) {
    for (std::uint64_t seed : {5u, 6u}) {
      const Tensor p = bumpy_icosphere_positions(mesh, 0.1, seed);
      const MeshLaplacian op(p, mesh.triangles, method);
      require_gradcheck(std::string("MeshLaplacian ") + laplacian_method_name(method),
                        [&](const std::vector<Tensor>& in) { return op.apply(in[0]); }, {grad_input(p)});
    }
    const MeshLaplacian op(hard.positions, hard.triangles, method);
    for (std::int64_t channels : {1, 3, 5}) {  // fixed-length accumulators and the general path
      const Tensor x = gr::testing::random_input({hard.positions.size(0), channels}, -1, 1, 9);
      // apply is linear: a step of 1e-2 has no truncation error and keeps the rounding
      // noise of the sliver's and the degenerate face's weights (near 1e6) small.
      GradcheckOptions options;
      options.eps = 1e-2;
      require_gradcheck(std::string("MeshLaplacian hard ") + laplacian_method_name(method),
                        [&](const std::vector<Tensor>& in) { return op.apply(in[0]); }, {x}, options);
    }
  }
  const MeshLaplacian hard_uniform(hard_triangles(), 6);
  require_gradcheck("MeshLaplacian uniform, one-neighbour and isolated vertices",
                    [&](const std::vector<Tensor>& in) { return hard_uniform.apply(in[0]); },
                    {gr::testing::random_input({6, 2}, -1, 1, 6)});
}

TEST_CASE("MeshLaplacian: values and gradients are bit-identical for 1, 2 and 8 threads",
          "[ops][mesh][laplacian][determinism]") {
  const raster::Mesh mesh = raster::make_icosphere(5);  // 10242 points: several chunks
  for (DType dtype : {DType::Float32, DType::Float64})
    for (LaplacianMethod method : kMethods) {
      INFO(laplacian_method_name(method) << ", " << dtype_name(dtype));
      const Tensor p = bumpy_icosphere_positions(mesh, 0.002, 8, dtype);
      check_same_bits_for_any_thread_count([&] {
        const MeshLaplacian op(p, mesh.triangles, method);
        return value_and_gradient([&](const Tensor& x) { return op.apply(x); }, p);
      });
    }
}

// x <- x + step * apply(x), `passes` times, and the gradient of a fixed
// weighting of the result (through smooth or the composite).
std::pair<Tensor, Tensor> smoothed_and_gradient(const std::function<Tensor(const Tensor&)>& smooth, const Tensor& p) {
  const Tensor x0 = p.detach().copy().set_requires_grad();
  const Tensor y = smooth(x0);
  backward(sum(y * y) + sum(y * Tensor::uniform(y.shape(), -1, 1, 78, y.dtype())));
  return {y.detach(), x0.grad()};
}

TEST_CASE("MeshLaplacian::smooth has the bits of its passes of x + step * apply(x), value and gradient, for every "
          "method in float32 and float64",
          "[ops][mesh][laplacian]") {
  const raster::Mesh mesh = raster::make_icosphere(3);  // 642 points
  for (DType dtype : {DType::Float32, DType::Float64})
    for (LaplacianMethod method : kMethods) {
      const Tensor p = bumpy_icosphere_positions(mesh, 0.1, 3, dtype);
      const MeshLaplacian op(p, mesh.triangles, method);
      for (std::int64_t channels : {3, 5})  // fixed-length accumulators and the general path
        for (int passes : {1, 2, 4})
          for (double step : {0.5, 0.3}) {  // 0.3: rounded to the dtype
            INFO(laplacian_method_name(method) << ", " << dtype_name(dtype) << ", " << channels << " channels, "
                                               << passes << " passes, step " << step);
            const Tensor x = Tensor::uniform({p.size(0), channels}, -1, 1, 11, dtype);
            const auto [value, gradient] =
                smoothed_and_gradient([&](const Tensor& in) { return op.smooth(in, passes, step); }, x);
            const auto [value_ref, gradient_ref] = smoothed_and_gradient(
                [&](const Tensor& in) {
                  Tensor y = in;
                  for (int k = 0; k < passes; ++k) y = y + step * op.apply(y);
                  return y;
                },
                x);
            CHECK(same_bits(value, value_ref));
            CHECK(same_bits(gradient, gradient_ref));
          }
    }
  // No pass: x itself.
  const MeshLaplacian op(mesh.triangles, mesh.num_vertices());
  const Tensor x = Tensor::uniform({mesh.num_vertices(), 3}, -1, 1, 12);
  CHECK(same_bits(op.smooth(x, 0, 0.5), x));
}

TEST_CASE("MeshLaplacian::smooth: gradients match float64 finite differences for every method, on random meshes and "
          "on one with a hole, an isolated vertex, a degenerate face, a sliver and a fin",
          "[ops][mesh][laplacian][gradcheck]") {
  const raster::Mesh mesh = raster::make_icosphere(1);
  const auto& hard = reference_mesh("hard");
  for (LaplacianMethod method : kMethods) {
    const Tensor p = bumpy_icosphere_positions(mesh, 0.1, 5);
    const MeshLaplacian op(p, mesh.triangles, method);
    for (int passes : {1, 3})
      require_gradcheck(std::string("MeshLaplacian::smooth ") + laplacian_method_name(method),
                        [&](const std::vector<Tensor>& in) { return op.smooth(in[0], passes, 0.4); },
                        {gr::testing::random_input({p.size(0), 3}, -1, 1, 13)});
    // Linear in x: a large step has no truncation error; small steps keep the
    // weights near 1e6 of the sliver and the degenerate face from blowing up.
    const MeshLaplacian hard_op(hard.positions, hard.triangles, method);
    GradcheckOptions options;
    options.eps = 1e-2;
    const double step = method == LaplacianMethod::Uniform ? 0.5 : 1e-6;
    for (std::int64_t channels : {1, 5})
      require_gradcheck(std::string("MeshLaplacian::smooth hard ") + laplacian_method_name(method),
                        [&](const std::vector<Tensor>& in) { return hard_op.smooth(in[0], 2, step); },
                        {gr::testing::random_input({hard.positions.size(0), channels}, -1, 1, 14)}, options);
  }
  const MeshLaplacian hard_uniform(hard_triangles(), 6);
  require_gradcheck("MeshLaplacian::smooth uniform, one-neighbour and isolated vertices",
                    [&](const std::vector<Tensor>& in) { return hard_uniform.smooth(in[0], 3, -0.7); },
                    {gr::testing::random_input({6, 2}, -1, 1, 15)});
}

TEST_CASE("MeshLaplacian::smooth: values and gradients are bit-identical for 1, 2 and 8 threads",
          "[ops][mesh][laplacian][determinism]") {
  const raster::Mesh mesh = raster::make_icosphere(5);  // 10242 points: several chunks
  for (LaplacianMethod method : kMethods) {
    INFO(laplacian_method_name(method));
    const Tensor p = bumpy_icosphere_positions(mesh, 0.002, 8);
    check_same_bits_for_any_thread_count([&] {
      const MeshLaplacian op(p, mesh.triangles, method);
      return smoothed_and_gradient([&](const Tensor& x) { return op.smooth(x, 3, 0.5); }, p);
    });
  }
}

TEST_CASE("MeshLaplacian: rejects values of the wrong shape or dtype and bad meshes, naming the argument",
          "[ops][mesh][laplacian][errors]") {
  const MeshLaplacian op(hard_triangles(), 6);
  CHECK_THROWS_WITH(op.apply(Tensor::zeros({5, 3})), Catch::Contains("argument 'x' must have shape [V, C] with V = 6"));
  CHECK_THROWS_AS(op.apply(Tensor::zeros({18})), ShapeError);
  CHECK_THROWS_AS(op.apply(Tensor::zeros({6, 3}, DType::Int32)), DTypeError);
  CHECK_THROWS_AS(op.apply(Tensor()), Error);
  CHECK_THROWS_WITH(op.smooth(Tensor::zeros({5, 3}), 1, 0.5),
                    Catch::Contains("MeshLaplacian::smooth: argument 'x' must have shape [V, C] with V = 6"));
  CHECK_THROWS_AS(op.smooth(Tensor::zeros({6, 3}, DType::Int32), 1, 0.5), DTypeError);
  CHECK_THROWS_WITH(op.smooth(Tensor::zeros({6, 3}), -1, 0.5), Catch::Contains("argument 'passes' must be >= 0"));
  CHECK_THROWS_WITH(op.smooth(Tensor::zeros({6, 3}), 1, std::nan("")), Catch::Contains("argument 'step' must be finite"));
  CHECK_THROWS_AS(MeshLaplacian(hard_triangles(), 4), IndexError);  // index 4
  CHECK_THROWS_AS(MeshLaplacian(Tensor::zeros({2, 3}), 6), DTypeError);
  CHECK_THROWS_WITH(MeshLaplacian(hard_triangles(), -1), Catch::Contains("'num_vertices' must be >= 0"));
  const Tensor p = Tensor::uniform({6, 3}, -1, 1, 1);
  CHECK_THROWS_WITH(MeshLaplacian(Tensor::zeros({6, 2}), hard_triangles(), LaplacianMethod::Cot),
                    Catch::Contains("MeshLaplacian: argument 'positions' must have shape [V, 3]"));
  CHECK_THROWS_WITH(MeshLaplacian(p, Tensor::zeros({2, 3}), LaplacianMethod::Cot),
                    Catch::Contains("MeshLaplacian") && Catch::Contains("'triangles'"));
  CHECK_THROWS_WITH(MeshLaplacian(p, hard_triangles(), LaplacianMethod(7)), Catch::Contains("'method'"));
  Tensor nan = p.copy();
  nan.data<float>()[4] = std::nanf("");
  CHECK_THROWS_AS(MeshLaplacian(nan, hard_triangles(), LaplacianMethod::CotCurv), ValueError);
}

TEST_CASE("MeshLaplacian: a bare vertex count beyond the memory budget is a MemoryError before any table is sized",
          "[ops][mesh][laplacian][errors]") {
  // An audit's finding: the count sized zero-filled tables (2^31: 16 GB for
  // the row starts alone, then an OOM kill), and INT64_MAX overflowed the
  // edge keys lo * V + hi (undefined behaviour, reported by the sanitizer job).
  const Tensor one = Tensor::from_vector<std::int32_t>({1, 2, 3}, {1, 3});
  CHECK_THROWS_AS(MeshLaplacian(one, std::int64_t(1) << 31), MemoryError);
  CHECK_THROWS_WITH(MeshLaplacian(one, INT64_MAX), Catch::Contains("MeshLaplacian") && Catch::Contains("vertices"));
  const MeshLaplacian small(one, 1000);  // unused vertices are fine within the budget
  CHECK(small.num_vertices() == 1000);
}
