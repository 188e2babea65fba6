// The C++ mesh ops against Python's gradraster.losses (torch, float64) on the
// meshes of tests/data/mesh_losses/reference.txt (written by generate.py
// there): an icosphere with moved vertices, one with a hole, an isolated
// vertex, a degenerate face, a sliver and a fin, and one with a zero-area
// face. Values and gradients agree to rounding (the two sum in different
// orders), each relative to the largest magnitude of its entry.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "ops/ops.h"
#include "ops/mesh/mesh_cases.h"

using namespace gr;
using gr::testing::ReferenceMesh;
using gr::testing::reference_meshes;

namespace {

void check_close(const std::vector<double>& got, const std::vector<double>& want, double rel, const std::string& what) {
  INFO(what);
  REQUIRE(got.size() == want.size());
  double scale = 0;
  for (double w : want) scale = std::max(scale, std::abs(w));
  double worst = 0;
  for (std::size_t k = 0; k < want.size(); ++k) worst = std::max(worst, std::abs(got[k] - want[k]));
  INFO("max |C++ - Python| = " << worst << ", largest |Python| = " << scale);
  CHECK(worst <= rel * std::max(scale, 1e-300));
}

// Compares the value of loss(positions) and, if the reference has it, its gradient.
void check_loss(const ReferenceMesh& m, const std::string& key, const std::function<Tensor(const Tensor&)>& loss,
                double rel = 1e-11) {
  const Tensor x = m.positions.detach().copy().set_requires_grad();
  const Tensor y = loss(x);
  check_close(y.to_vector(), m.value(key), rel, m.name + ": " + key);
  if (m.values.count(key + ".grad") == 0) return;
  backward(y);
  check_close(x.grad().to_vector(), m.value(key + ".grad"), rel, m.name + ": " + key + ".grad");
}

}  // namespace

TEST_CASE("mesh losses: values and gradients match Python's gradraster.losses on the reference meshes",
          "[ops][mesh][losses][reference]") {
  REQUIRE(reference_meshes().size() == 3);
  for (const ReferenceMesh& m : reference_meshes()) {
    const Tensor& t = m.triangles;
    check_loss(m, "mesh_edge_loss", [&](const Tensor& x) { return mesh_edge_loss(x, t); });
    check_loss(m, "mesh_edge_loss target 0.7", [&](const Tensor& x) { return mesh_edge_loss(x, t, 0.7); });
    for (LaplacianMethod method : {LaplacianMethod::Uniform, LaplacianMethod::Cot, LaplacianMethod::CotCurv})
      check_loss(m, std::string("mesh_laplacian_smoothing ") + laplacian_method_name(method),
                 [&](const Tensor& x) { return mesh_laplacian_smoothing(x, t, method); },
                 // The hard mesh's degenerate face gives cotangents near 1e6 (area clamped at
                 // 1e-6), whose rounding the curvature normalization magnifies.
                 method == LaplacianMethod::CotCurv ? 1e-8 : 1e-11);
    // (zero area: the collinear face's normal is rounding noise clamped to eps, cos ~ 1e-9.)
    check_loss(m, "mesh_normal_consistency", [&](const Tensor& x) { return mesh_normal_consistency(x, t); },
               m.name == "zero_area" ? 1e-7 : 1e-11);
  }
}

TEST_CASE("vertex normals and large steps: values and gradients match Python's gradraster.losses on the "
          "reference meshes",
          "[ops][mesh][reference]") {
  for (const ReferenceMesh& m : reference_meshes()) {
    if (m.values.count("vertex_normals") == 0) continue;  // (values of the losses only)
    const Tensor& t = m.triangles;
    const std::int64_t V = m.positions.size(0);
    // Rows of weight 0 (generate.py) have face normals summing to 0: there the value is
    // rounding noise over eps (torch's cross may fuse its products), so they are left out.
    const Tensor weight = Tensor::from_values(m.value("vertex_normals weight"), {V, 3}, DType::Float64);
    const Tensor kept = cast(not_equal(weight, 0.0), DType::Float64);
    const Tensor want = Tensor::from_values(m.value("vertex_normals"), {V, 3}, DType::Float64);
    check_close((vertex_normals(m.positions, t) * kept).to_vector(), (want * kept).to_vector(), 1e-12,
                m.name + ": vertex_normals");
    check_loss(m, "vertex_normals weighted sum", [&](const Tensor& x) { return sum(vertex_normals(x, t) * weight); });

    const LargeSteps ls(m.positions, t, 2.5);
    check_close(ls.matrix().to_vector(), m.value("large_steps lambda 2.5 matrix"), 0, m.name + ": matrix");
    check_close(ls.to_differential(m.positions).to_vector(), m.value("large_steps lambda 2.5 to_differential"), 1e-14,
                m.name + ": to_differential");
    check_close(ls.from_differential(m.positions).to_vector(), m.value("large_steps lambda 2.5 from_differential"),
                1e-13, m.name + ": from_differential");
    const LargeSteps alpha = LargeSteps::with_alpha(m.positions, t, 0.3);
    check_close(alpha.from_differential(m.positions).to_vector(), m.value("large_steps alpha 0.3 from_differential"),
                1e-13, m.name + ": alpha from_differential");
  }
}
