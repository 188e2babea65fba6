// vertex_normals: against a loop over the definition (float64), pointing out
// of a sphere and up from a counter-clockwise grid, 0 at an isolated vertex,
// float64 finite differences on random meshes and on one with a hole, an
// isolated vertex, a degenerate face, a sliver and a fin; against the
// composite of tensor ops it replaced (its values bit for bit); the same bits
// for any thread count.
#include <catch2/catch.hpp>

#include <cmath>
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

// sum over faces at i of (p1 - p0) x (p2 - p0), normalized (0 stays 0).
std::vector<double> loop_normals(const Tensor& p, const Tensor& t) {
  std::vector<double> s(static_cast<std::size_t>(3 * p.size(0)), 0.0);
  for (std::int64_t f = 0; f < t.size(0); ++f) {
    std::int64_t c[3];
    for (int k = 0; k < 3; ++k) c[k] = std::int64_t(t.at({f, k}));
    double u[3], v[3];
    for (int d = 0; d < 3; ++d) u[d] = p.at({c[1], d}) - p.at({c[0], d}), v[d] = p.at({c[2], d}) - p.at({c[0], d});
    const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) s[3 * c[k] + d] += n[d];
  }
  for (std::size_t i = 0; i < s.size(); i += 3) {
    const double len = std::sqrt(s[i] * s[i] + s[i + 1] * s[i + 1] + s[i + 2] * s[i + 2]);
    for (int d = 0; d < 3; ++d) s[i + d] = len > 0 ? s[i + d] / len : 0.0;
  }
  return s;
}

// vertex_normals as the tensor ops it was once written with: gathers of the
// corners, cross, scatter_add of the three corner columns, normalize.
Tensor composite_normals(const Tensor& p, const Tensor& t) {
  auto corner = [&](int k) { return reshape(slice(t, 1, k, k + 1), {t.size(0)}); };
  const Tensor i0 = corner(0), i1 = corner(1), i2 = corner(2);
  const Tensor p0 = gather(p, i0);
  const Tensor face = cross(gather(p, i1) - p0, gather(p, i2) - p0);
  return normalize(scatter_add(concat({face, face, face}, 0), concat({i0, i1, i2}, 0), p.size(0)));
}

// normals(p) and the gradient of a fixed weighting of it with respect to p.
std::pair<Tensor, Tensor> value_and_gradient(Tensor (*normals)(const Tensor&, const Tensor&), const Tensor& p,
                                             const Tensor& t) {
  const Tensor x = p.detach().copy().set_requires_grad();
  const Tensor n = normals(x, t);
  backward(sum(n * Tensor::uniform(n.shape(), -1, 1, 5, n.dtype())));
  return {n.detach(), x.grad()};
}

Tensor default_normals(const Tensor& p, const Tensor& t) { return vertex_normals(p, t); }

}  // namespace

TEST_CASE("vertex_normals: values are the composite's bits and gradients agree with it to rounding",
          "[ops][mesh][vertex_normals]") {
  const raster::Mesh ico = raster::make_icosphere(3);
  const auto& hard = reference_mesh("hard");
  for (DType dtype : {DType::Float32, DType::Float64}) {
    for (const auto& [p, t] : {std::pair{bumpy_icosphere_positions(ico, 0.1, 4, dtype), ico.triangles},
                               std::pair{cast(hard.positions, dtype), hard.triangles}}) {
      INFO(dtype_name(dtype) << ", " << t.size(0) << " faces");
      const auto [value, gradient] = value_and_gradient(default_normals, p, t);
      const auto [value_ref, gradient_ref] = value_and_gradient(composite_normals, p, t);
      CHECK(same_bits(value, value_ref));
      // The composite rounds each of its steps to the dtype; the op sums in double.
      const std::vector<double> g = gradient.to_vector(), g_ref = gradient_ref.to_vector();
      double largest = 0, worst = 0;
      for (std::size_t i = 0; i < g.size(); ++i) {
        largest = std::max(largest, std::abs(g_ref[i]));
        worst = std::max(worst, std::abs(g[i] - g_ref[i]));
      }
      CHECK(largest > 0);
      CHECK(worst <= (dtype == DType::Float32 ? 1e-5 : 1e-13) * largest);
    }
  }
}

TEST_CASE("vertex_normals: values and gradients are bit-identical for 1, 2 and 8 threads",
          "[ops][mesh][vertex_normals][determinism]") {
  const raster::Mesh mesh = raster::make_icosphere(5);  // 10242 points, 20480 faces: several chunks
  for (DType dtype : {DType::Float32, DType::Float64}) {
    INFO(dtype_name(dtype));
    const Tensor p = bumpy_icosphere_positions(mesh, 0.002, 9, dtype);
    check_same_bits_for_any_thread_count([&] { return value_and_gradient(default_normals, p, mesh.triangles); });
  }
}

TEST_CASE("vertex_normals: the normalized sums of the faces' cross products, out of a sphere, 0 where isolated",
          "[ops][mesh][vertex_normals]") {
  const raster::Mesh ico = raster::make_icosphere(2);
  const Tensor p = bumpy_icosphere_positions(ico, 0.05, 2);
  const std::vector<double> got = vertex_normals(p, ico.triangles).to_vector(), want = loop_normals(p, ico.triangles);
  for (std::size_t k = 0; k < want.size(); ++k) CHECK(got[k] == Approx(want[k]).margin(1e-14));
  // Unit sphere: the normal is nearly the position.
  const Tensor n = vertex_normals(ico.positions, ico.triangles);
  for (std::int64_t i = 0; i < ico.num_vertices(); ++i) {
    double along = 0;
    for (std::int64_t k = 0; k < 3; ++k) along += n.at({i, k}) * ico.positions.at({i, k});
    CHECK(along > 0.99);
  }
  // A counter-clockwise plane seen from +z: (0, 0, 1) everywhere.
  const raster::Mesh plane = raster::make_plane(3, 3);
  const Tensor up = vertex_normals(plane.positions, plane.triangles);
  for (std::int64_t i = 0; i < plane.num_vertices(); ++i) {
    CHECK(std::abs(up.at({i, 2})) == Approx(1.0).epsilon(1e-6));
    CHECK(up.at({i, 2}) == up.at({0, 2}));
  }
  // The hard mesh: its isolated vertex (index 42) gets 0, as does w of the degenerate face (a, w, w).
  const auto& hard = reference_mesh("hard");
  const Tensor h = vertex_normals(hard.positions, hard.triangles);
  for (std::int64_t k = 0; k < 3; ++k) {
    CHECK(h.at({42, k}) == 0);
    CHECK(h.at({43, k}) == 0);
  }
}

TEST_CASE("vertex_normals: gradients match float64 finite differences on random meshes and on a hard mesh",
          "[ops][mesh][vertex_normals][gradcheck]") {
  const raster::Mesh ico = raster::make_icosphere(1);
  for (std::uint64_t seed : {7u, 8u}) {
    const Tensor p = bumpy_icosphere_positions(ico, 0.1, seed);
    require_gradcheck("vertex_normals, random icosphere",
                      [&](const std::vector<Tensor>& in) { return vertex_normals(in[0], ico.triangles); },
                      {grad_input(p)});
  }
  // The hard mesh, weighted as generate.py does: 0 on the rows whose face normals sum to 0
  // (w of the degenerate face: its normal has no direction, its gradient is of order 1/eps).
  const auto& hard = reference_mesh("hard");
  const Tensor weight = Tensor::from_values(hard.value("vertex_normals weight"), {hard.positions.size(0), 3},
                                            DType::Float64);
  GradcheckOptions options;
  options.eps = 1e-6;  // the sliver is lifted 1e-3 off its edge (as in the Python tests)
  require_gradcheck("vertex_normals, hard mesh",
                    [&](const std::vector<Tensor>& in) { return vertex_normals(in[0], hard.triangles) * weight; },
                    {grad_input(hard.positions)}, options);
}

TEST_CASE("vertex_normals: a triangle list written in place between calls gives the new list's normals",
          "[ops][mesh][vertex_normals]") {
  const raster::Mesh ico = raster::make_icosphere(2);
  const Tensor p = bumpy_icosphere_positions(ico, 0.05, 3);
  Tensor t = ico.triangles.copy();
  const Tensor outward = vertex_normals(p, t);
  // Flip every face (swap corners 1 and 2): the same tensor, written in place.
  std::int32_t* ids = t.data<std::int32_t>();
  for (std::int64_t f = 0; f < t.size(0); ++f) std::swap(ids[3 * f + 1], ids[3 * f + 2]);
  const Tensor inward = vertex_normals(p, t);
  CHECK(same_bits(inward, vertex_normals(p, t.copy())));
  const std::vector<double> a = outward.to_vector(), b = inward.to_vector();
  for (std::size_t k = 0; k < a.size(); ++k) CHECK(b[k] == Approx(-a[k]).margin(1e-12));
  // Relabel the vertices in place (i -> i + 1 mod V): each vertex now has other
  // faces. Each write takes data() anew: that is how a write is counted (autodiff/base/storage.h).
  const std::int32_t V = std::int32_t(p.size(0));
  ids = t.data<std::int32_t>();
  for (std::int64_t k = 0; k < t.numel(); ++k) ids[k] = (ids[k] + 1) % V;
  const Tensor relabelled = vertex_normals(p, t);
  CHECK(same_bits(relabelled, vertex_normals(p, t.copy())));
  CHECK_FALSE(same_bits(relabelled, inward));
}
