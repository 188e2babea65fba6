// mesh_edge_loss, mesh_laplacian_smoothing and mesh_normal_consistency: values
// worked out by hand on a cube, a tetrahedron, a flat grid, a fan and a
// fan of fins; float64 finite differences on random meshes and on one with a
// hole, an isolated vertex, a degenerate face, a sliver and a fin; the
// Laplacian's weights held constant (PyTorch3D's gradient); empty meshes;
// float32; bit-identical results for 1, 2 and 8 threads; errors naming the
// argument. (Agreement with Python's gradraster.losses: test_reference.cpp.)
#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <string>
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

constexpr LaplacianMethod kMethods[] = {LaplacianMethod::Uniform, LaplacianMethod::Cot, LaplacianMethod::CotCurv};

Tensor tris(const std::vector<std::int32_t>& t) { return Tensor::from_vector(t, {std::int64_t(t.size() / 3), 3}); }
Tensor points(const std::vector<double>& p) {
  return Tensor::from_values(p, {std::int64_t(p.size() / 3), 3}, DType::Float64);
}

// Unit cube, each square split by a diagonal: 12 sides of length 1, 6 diagonals of sqrt 2.
struct Mesh {
  Tensor positions, triangles;
};
Mesh cube() {
  std::vector<double> p;
  for (int x : {0, 1})
    for (int y : {0, 1})
      for (int z : {0, 1}) p.insert(p.end(), {double(x), double(y), double(z)});
  // Quads (outward), split along (a, c).
  const int q[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  std::vector<std::int32_t> t;
  for (const auto& s : q) t.insert(t.end(), {s[0], s[1], s[2], s[0], s[2], s[3]});
  return {points(p), tris(t)};
}
// Regular, edge length 2 sqrt 2.
Mesh tetrahedron() {
  return {points({1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1}), tris({0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2})};
}
// An n x n grid on [0, 1]^2 in the plane z = 0, faces counter-clockwise from +z.
Mesh grid(int n) {
  std::vector<double> p;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) p.insert(p.end(), {double(i) / n, double(j) / n, 0.0});
  std::vector<std::int32_t> t;
  auto id = [n](int i, int j) { return std::int32_t(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      t.insert(t.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1)});
  return {points(p), tris(t)};
}

double value(const Tensor& t) { return t.to_vector().at(0); }

// The meshes of the gradient checks: two random icospheres and the hard reference mesh.
std::vector<std::pair<std::string, Mesh>> grad_meshes() {
  const raster::Mesh ico = raster::make_icosphere(1);
  const auto& hard = reference_mesh("hard");
  return {{"random icosphere 1", {bumpy_icosphere_positions(ico, 0.1, 11), ico.triangles}},
          {"random icosphere 2", {bumpy_icosphere_positions(ico, 0.2, 12), ico.triangles}},
          {"hard mesh", {hard.positions, hard.triangles}}};
}

}  // namespace

TEST_CASE("mesh_edge_loss: the mean squared deviation of the distinct edge lengths, by hand on a cube and a "
          "tetrahedron",
          "[ops][mesh][losses]") {
  const Mesh c = cube();
  CHECK(value(mesh_edge_loss(c.positions, c.triangles)) == Approx((12 * 1.0 + 6 * 2.0) / 18).epsilon(1e-14));
  const Mesh t = tetrahedron();
  CHECK(value(mesh_edge_loss(t.positions, t.triangles, 2 * std::sqrt(2.0))) == Approx(0).margin(1e-14));
  CHECK(value(mesh_edge_loss(t.positions, t.triangles, 1.0)) ==
        Approx(std::pow(2 * std::sqrt(2.0) - 1, 2)).epsilon(1e-14));
}

TEST_CASE("mesh_laplacian_smoothing: by hand on a fan with a raised centre and zero inside a flat grid",
          "[ops][mesh][losses]") {
  // Centre (0, 0, h), ring (+-1, 0, 0), (0, +-1, 0): |r_centre| = h, each ring vertex's
  // |r| = |(-1, 0, h / 3)|.
  const double h = 0.6;
  const Tensor p = points({0, 0, h, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0});
  const Tensor f = tris({0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 1});
  CHECK(value(mesh_laplacian_smoothing(p, f)) == Approx((h + 4 * std::sqrt(1 + h * h / 9)) / 5).epsilon(1e-14));
  // A flat regular grid: r = 0 at the 16 inner vertices (uniform and cot), so only the border counts.
  const Mesh g = grid(5);
  for (LaplacianMethod method : {LaplacianMethod::Uniform, LaplacianMethod::Cot}) {
    const Tensor r = MeshLaplacian(g.positions, g.triangles, method).apply(g.positions);
    double border = 0;
    int inner = 0;
    for (std::int64_t i = 0; i < g.positions.size(0); ++i) {
      const double x = g.positions.at({i, 0}), y = g.positions.at({i, 1});
      const double n = std::hypot(r.at({i, 0}), r.at({i, 1}), r.at({i, 2}));
      if (x > 0 && x < 1 && y > 0 && y < 1) {
        ++inner;
        CHECK(n < 1e-14);
      } else {
        border += n;
      }
    }
    CHECK(inner == 16);
    CHECK(value(mesh_laplacian_smoothing(g.positions, g.triangles, method)) == Approx(border / 36).epsilon(1e-12));
  }
}

TEST_CASE("mesh_normal_consistency: by hand on a flat grid, a cube, a tetrahedron and four fins on one edge",
          "[ops][mesh][losses]") {
  const Mesh g = grid(4);
  CHECK(value(mesh_normal_consistency(g.positions, g.triangles)) == Approx(0).margin(1e-15));
  const Mesh c = cube();  // 12 right-angle edges (1 each) and 6 flat diagonals (0)
  CHECK(value(mesh_normal_consistency(c.positions, c.triangles)) == Approx(12.0 / 18).epsilon(1e-14));
  const Mesh t = tetrahedron();  // face normals at cos = -1/3 on all 6 edges
  CHECK(value(mesh_normal_consistency(t.positions, t.triangles)) == Approx(4.0 / 3).epsilon(1e-14));
  // Four fins at right angles on the edge (0, 1): 4 of the 6 pairs fold (1), 2 lie flat (0).
  const Tensor p = points({0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0});
  const Tensor f = tris({0, 1, 2, 0, 1, 3, 0, 1, 4, 0, 1, 5});
  CHECK(value(mesh_normal_consistency(p, f)) == Approx(4.0 / 6).epsilon(1e-14));
  // Orientation does not matter: flipping every other face changes nothing.
  const Tensor flipped = tris({0, 1, 2, 1, 0, 3, 0, 1, 4, 1, 0, 5});
  CHECK(value(mesh_normal_consistency(p, flipped)) == Approx(4.0 / 6).epsilon(1e-14));
}

TEST_CASE("mesh losses: gradients match float64 finite differences on random meshes and on one with a hole, an "
          "isolated vertex, a degenerate face, a sliver and a fin",
          "[ops][mesh][losses][gradcheck]") {
  for (const auto& [name, m] : grad_meshes()) {
    const Tensor& t = m.triangles;
    // The hard mesh's sliver is lifted 1e-3 off its edge: steps of 1e-6 (as the Python
    // tests take) keep the finite differences' truncation error small there.
    GradcheckOptions options;
    if (name == "hard mesh") options.eps = 1e-6;
    for (double target : {0.0, 0.5})
      require_gradcheck("mesh_edge_loss, " + name,
                        [&](const std::vector<Tensor>& in) { return mesh_edge_loss(in[0], t, target); },
                        {grad_input(m.positions)}, options);
    require_gradcheck("mesh_normal_consistency, " + name,
                      [&](const std::vector<Tensor>& in) { return mesh_normal_consistency(in[0], t); },
                      {grad_input(m.positions)}, options);
    // The Laplacian's weights are constants for the gradient (PyTorch3D's): check the loss
    // with the weights frozen at the positions, and that the loss's gradient is its gradient.
    for (LaplacianMethod method : kMethods) {
      const MeshLaplacian frozen(m.positions, t, method);
      auto with_frozen = [&](const Tensor& x) { return mean(length(frozen.apply(x))); };
      require_gradcheck(std::string("mesh_laplacian_smoothing ") + laplacian_method_name(method) + ", " + name,
                        [&](const std::vector<Tensor>& in) { return with_frozen(in[0]); }, {grad_input(m.positions)},
                        options);
      const Tensor x = grad_input(m.positions), y = grad_input(m.positions);
      backward(mesh_laplacian_smoothing(x, t, method));
      backward(with_frozen(y));
      CHECK(same_bits(x.grad(), y.grad()));
    }
  }
}

TEST_CASE("mesh losses: a zero-area face gives finite losses and gradients", "[ops][mesh][losses]") {
  const auto& m = reference_mesh("zero_area");
  std::vector<std::function<Tensor(const Tensor&)>> losses = {
      [&](const Tensor& x) { return mesh_edge_loss(x, m.triangles, 0.3); },
      [&](const Tensor& x) { return mesh_normal_consistency(x, m.triangles); },
      [&](const Tensor& x) { return sum(vertex_normals(x, m.triangles)); }};
  for (LaplacianMethod method : kMethods)
    losses.push_back([&, method](const Tensor& x) { return mesh_laplacian_smoothing(x, m.triangles, method); });
  for (const auto& loss : losses) {
    const Tensor x = grad_input(m.positions);
    const Tensor y = loss(x);
    backward(y);
    CHECK(gr::testing::all_finite(y));
    CHECK(gr::testing::all_finite(x.grad()));
  }
}

TEST_CASE("mesh losses: meshes without faces, or without an edge of two faces, give 0 with a zero gradient in "
          "the positions' dtype",
          "[ops][mesh][losses]") {
  const Tensor no_faces = Tensor::zeros({0, 3}, DType::Int32);
  const std::vector<std::function<Tensor(const Tensor&)>> losses = {
      [&](const Tensor& x) { return mesh_edge_loss(x, no_faces, 0.5); },
      [&](const Tensor& x) { return mesh_laplacian_smoothing(x, no_faces, LaplacianMethod::Cot); },
      [&](const Tensor& x) { return mesh_normal_consistency(x, no_faces); },
      [&](const Tensor& x) { return mesh_normal_consistency(x, tris({0, 1, 2})); }};  // no shared edge
  for (DType dtype : {DType::Float32, DType::Float64})
    for (const auto& loss : losses) {
      const Tensor x = Tensor::uniform({4, 3}, -1, 1, 2, dtype).set_requires_grad();
      const Tensor y = loss(x);
      CHECK(y.rank() == 0);
      CHECK(y.dtype() == dtype);
      CHECK(value(y) == 0);
      backward(y);
      for (double g : x.grad().to_vector()) CHECK(g == 0);
    }
  // An isolated vertex adds |p| to the uniform and cot sums and nothing to cotcurv's.
  const auto& hard = reference_mesh("hard");
  const std::int64_t V = hard.positions.size(0);
  const Tensor isolated = slice(hard.positions, 0, V - 4, V - 3);  // generate.py adds it first
  const Tensor others = concat({slice(hard.positions, 0, 0, V - 4), slice(hard.positions, 0, V - 3, V)}, 0);
  std::vector<std::int32_t> t;
  for (double i : hard.triangles.to_vector()) t.push_back(std::int32_t(i) > V - 4 ? std::int32_t(i) - 1 : std::int32_t(i));
  for (LaplacianMethod method : kMethods) {
    const double with = value(mesh_laplacian_smoothing(hard.positions, hard.triangles, method)) * double(V);
    const double without = value(mesh_laplacian_smoothing(others, tris(t), method)) * double(V - 1);
    const double extra = method == LaplacianMethod::CotCurv ? 0.0 : value(length(isolated));
    CHECK(with == Approx(without + extra).epsilon(1e-12));
  }
}

TEST_CASE("mesh losses: float32 positions give float32 losses and gradients close to float64's",
          "[ops][mesh][losses]") {
  const raster::Mesh ico = raster::make_icosphere(2);
  const Tensor p64 = bumpy_icosphere_positions(ico, 0.1, 9);
  const Tensor p32 = cast(p64, DType::Float32);
  const std::vector<std::function<Tensor(const Tensor&)>> losses = {
      [&](const Tensor& x) { return mesh_edge_loss(x, ico.triangles, 0.2); },
      [&](const Tensor& x) { return mesh_laplacian_smoothing(x, ico.triangles, LaplacianMethod::Uniform); },
      [&](const Tensor& x) { return mesh_laplacian_smoothing(x, ico.triangles, LaplacianMethod::Cot); },
      [&](const Tensor& x) { return mesh_laplacian_smoothing(x, ico.triangles, LaplacianMethod::CotCurv); },
      [&](const Tensor& x) { return mesh_normal_consistency(x, ico.triangles); }};
  for (const auto& loss : losses) {
    const Tensor x32 = grad_input(p32), x64 = grad_input(p64);
    const Tensor y32 = loss(x32);
    backward(y32);
    const Tensor y64 = loss(x64);
    backward(y64);
    CHECK(y32.dtype() == DType::Float32);
    CHECK(value(y32) == Approx(value(y64)).epsilon(1e-5));
    CHECK(x32.grad().dtype() == DType::Float32);
    CHECK(gr::testing::max_relative_difference(x32.grad().to_vector(), x64.grad().to_vector()) < 1e-4);
  }
}

TEST_CASE("mesh losses: values and gradients are bit-identical for 1, 2 and 8 threads",
          "[ops][mesh][losses][determinism]") {
  const raster::Mesh ico = raster::make_icosphere(5);  // 10242 vertices, 20480 faces
  for (DType dtype : {DType::Float32, DType::Float64}) {
    const Tensor p = bumpy_icosphere_positions(ico, 0.002, 3, dtype);
    auto run = [&](int threads) {
      set_num_threads(threads);
      const Tensor x = grad_input(p);
      std::vector<Tensor> out = {mesh_edge_loss(x, ico.triangles, 0.01), mesh_normal_consistency(x, ico.triangles),
                                 vertex_normals(x, ico.triangles)};
      for (LaplacianMethod method : kMethods) out.push_back(mesh_laplacian_smoothing(x, ico.triangles, method));
      Tensor total = sum(out[2] * Tensor::uniform(out[2].shape(), -1, 1, 4, dtype));
      for (std::size_t k = 0; k < out.size(); ++k)
        if (k != 2) total = total + out[k];
      backward(total);
      out.push_back(x.grad());
      set_num_threads(0);
      return out;
    };
    const std::vector<Tensor> one = run(1);
    for (int threads : {2, 8}) {
      const std::vector<Tensor> other = run(threads);
      for (std::size_t k = 0; k < one.size(); ++k) {
        INFO(dtype_name(dtype) << ", " << threads << " threads, output " << k);
        CHECK(same_bits(one[k], other[k]));
      }
    }
  }
}

TEST_CASE("mesh losses and vertex normals: bad meshes are refused with errors naming the function and argument",
          "[ops][mesh][losses][errors]") {
  const Mesh t = tetrahedron();
  const std::vector<std::pair<std::string, std::function<Tensor(const Tensor&, const Tensor&)>>> fns = {
      {"mesh_edge_loss", [](const Tensor& p, const Tensor& f) { return mesh_edge_loss(p, f); }},
      {"mesh_laplacian_smoothing", [](const Tensor& p, const Tensor& f) { return mesh_laplacian_smoothing(p, f); }},
      {"mesh_normal_consistency", [](const Tensor& p, const Tensor& f) { return mesh_normal_consistency(p, f); }},
      {"vertex_normals", [](const Tensor& p, const Tensor& f) { return vertex_normals(p, f); }},
      {"LargeSteps", [](const Tensor& p, const Tensor& f) { return LargeSteps(p, f, 1.0).matrix(); }}};
  Tensor nan = t.positions.copy();
  nan.data<double>()[5] = std::nan("");
  for (const auto& [name, fn] : fns) {
    INFO(name);
    using Catch::Contains;
    CHECK_THROWS_WITH(fn(slice(t.positions, 1, 0, 2), t.triangles),
                      Contains(name + ": argument 'positions' must have shape [V, 3]"));
    CHECK_THROWS_AS(fn(slice(t.positions, 1, 0, 2), t.triangles), ShapeError);
    CHECK_THROWS_WITH(fn(cast(t.positions, DType::Int32), t.triangles), Contains(name) && Contains("'positions'"));
    CHECK_THROWS_AS(fn(cast(t.positions, DType::Int32), t.triangles), DTypeError);
    CHECK_THROWS_WITH(fn(t.positions, cast(t.triangles, DType::Float64)), Contains(name) && Contains("'triangles'"));
    CHECK_THROWS_WITH(fn(t.positions, Tensor::zeros({4, 4}, DType::Int32)),
                      Contains(name + ": argument 'triangles' must have shape [M, 3]"));
    CHECK_THROWS_AS(fn(t.positions, tris({0, 1, 4})), IndexError);
    CHECK_THROWS_WITH(fn(t.positions, tris({0, 1, 4})), Contains(name) && Contains("4"));
    CHECK_THROWS_AS(fn(t.positions, tris({0, -1, 2})), IndexError);
    CHECK_THROWS_WITH(fn(nan, t.triangles), Contains(name) && Contains("positions"));
    CHECK_THROWS_AS(fn(Tensor(), t.triangles), Error);
  }
  CHECK_THROWS_WITH(mesh_edge_loss(t.positions, t.triangles, std::nan("")), Catch::Contains("'target_length'"));
  CHECK_THROWS_WITH(mesh_normal_consistency(t.positions, t.triangles, 0.0), Catch::Contains("'eps'"));
  CHECK_THROWS_WITH(vertex_normals(t.positions, t.triangles, -1.0), Catch::Contains("eps"));
}
