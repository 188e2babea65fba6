// Mesh Laplacians: construction of the rows, weights and scales (serial, in a
// fixed order), and the sparse product and its adjoint (one recorded op, in
// parallel over rows through detail::row_sums).
#include "ops/mesh/laplacian.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "autodiff/base/dtype.h"
#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/tensor/elementwise.h"
#include "ops/mesh/row_sums.h"
#include "ops/mesh/topology.h"

namespace gr {

const char* laplacian_method_name(LaplacianMethod method) {
  switch (method) {
    case LaplacianMethod::Uniform: return "uniform";
    case LaplacianMethod::Cot: return "cot";
    case LaplacianMethod::CotCurv: return "cotcurv";
  }
  return "unknown";
}

// Rows of W (one entry per neighbour; a self edge (i, i) twice) and, in float
// and double, the entries' weights w_e (Cot, CotCurv), the row scales S and
// the row weight sums D (CotCurv).
struct MeshLaplacian::Operator {
  template <class T>
  struct Coefficients {
    std::vector<T> weight, scale, diag;
  };
  LaplacianMethod method;
  detail::VertexRows rows;
  Coefficients<float> f32;
  Coefficients<double> f64;

  template <class T>
  const Coefficients<T>& coefficients() const {
    if constexpr (std::is_same_v<T, float>) return f32;
    else return f64;
  }
  // Rounds the float64 coefficients to float32 too.
  void finish() {
    f32.weight.assign(f64.weight.begin(), f64.weight.end());
    f32.scale.assign(f64.scale.begin(), f64.scale.end());
    f32.diag.assign(f64.diag.begin(), f64.diag.end());
  }
};

namespace {

using Operator = MeshLaplacian::Operator;

// Heron's formula with the squared area clamped at 1e-12 and the corner
// cotangents (b^2 + c^2 - a^2) / (4 area), as PyTorch3D's cot_laplacian.
// p: the three corners; returns the area, cot[k] for corner k.
template <class P>
double face_cotangents(const P& p, double cot[3]) {
  auto dist = [](const double* u, const double* v) {
    const double d0 = u[0] - v[0], d1 = u[1] - v[1], d2 = u[2] - v[2];
    return std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
  };
  const double a = dist(p[1], p[2]), b = dist(p[0], p[2]), c = dist(p[0], p[1]);
  const double s = 0.5 * (a + b + c);
  const double area = std::sqrt(std::max(s * (s - a) * (s - b) * (s - c), 1e-12));
  const double a2 = a * a, b2 = b * b, c2 = c * c;
  cot[0] = (b2 + c2 - a2) / (4.0 * area);
  cot[1] = (a2 + c2 - b2) / (4.0 * area);
  cot[2] = (a2 + b2 - c2) / (4.0 * area);
  return area;
}

// The cotangent weights W_e of each edge (summed over its face sides in side
// order; symmetric by construction) and the vertex areas A_i (face areas added
// to their corners in face order).
void cot_weights(const Tensor& positions, const Tensor& triangles, const detail::MeshEdges& edges,
                 std::vector<double>& edge_weight, std::vector<double>& vertex_area) {
  const std::int64_t nv = positions.size(0), nf = triangles.size(0);
  std::vector<double> p(static_cast<std::size_t>(3 * nv));
  dispatch_float(positions.dtype(), "MeshLaplacian", [&](auto tag) {
    using T = decltype(tag);
    const T* src = positions.data<T>();
    for (std::int64_t k = 0; k < 3 * nv; ++k) p[k] = double(src[k]);
  });
  const std::int32_t* t = triangles.data<std::int32_t>();
  edge_weight.assign(static_cast<std::size_t>(edges.size()), 0.0);
  vertex_area.assign(static_cast<std::size_t>(nv), 0.0);
  for (std::int64_t f = 0; f < nf; ++f) {
    const double* corner[3] = {&p[3 * t[3 * f]], &p[3 * t[3 * f + 1]], &p[3 * t[3 * f + 2]]};
    double cot[3];
    const double area = face_cotangents(corner, cot);
    for (int k = 0; k < 3; ++k) {
      edge_weight[edges.side_edge[3 * f + k]] += cot[k];
      vertex_area[t[3 * f + k]] += area;
    }
  }
}

std::shared_ptr<const Operator> build(const Tensor& positions, const Tensor& triangles, std::int64_t nv,
                                      LaplacianMethod method) {
  return guard_allocation("MeshLaplacian", [&] {
    auto op = std::make_shared<Operator>();
    op->method = method;
    const detail::MeshEdges edges = detail::mesh_edges(triangles, nv);
    op->rows = detail::edge_rows(edges, nv, /*self_edges=*/true);
    const auto& rows = op->rows;
    auto& c = op->f64;
    c.scale.resize(static_cast<std::size_t>(nv));
    if (method == LaplacianMethod::Uniform) {
      for (std::int64_t i = 0; i < nv; ++i) {
        const std::int64_t degree = rows.start[i + 1] - rows.start[i];
        c.scale[i] = degree > 0 ? 1.0 / double(degree) : 0.0;
      }
    } else {
      std::vector<double> edge_weight, vertex_area;
      cot_weights(positions, triangles, edges, edge_weight, vertex_area);
      c.weight.resize(rows.edge.size());
      for (std::size_t e = 0; e < rows.edge.size(); ++e) c.weight[e] = edge_weight[rows.edge[e]];
      std::vector<double> weight_sum(static_cast<std::size_t>(nv), 0.0);
      for (std::int64_t i = 0; i < nv; ++i)
        for (std::int64_t e = rows.start[i]; e < rows.start[i + 1]; ++e) weight_sum[i] += c.weight[e];
      if (method == LaplacianMethod::Cot) {
        // PyTorch3D: rows whose weights sum to <= 0 are multiplied by the sum.
        for (std::int64_t i = 0; i < nv; ++i) c.scale[i] = weight_sum[i] > 0 ? 1.0 / weight_sum[i] : weight_sum[i];
      } else {
        for (std::int64_t i = 0; i < nv; ++i) c.scale[i] = vertex_area[i] > 0 ? 0.25 * (1.0 / vertex_area[i]) : 0.0;
        c.diag = std::move(weight_sum);
      }
    }
    op->finish();
    return std::shared_ptr<const Operator>(std::move(op));
  });
}

// r = L x (see laplacian.h): the row's sum from 0 in ascending neighbour
// order, then one product and one difference in T.
template <class T>
void laplacian_forward(const Operator& op, const T* x, T* out, std::int64_t C) {
  const auto& k = op.coefficients<T>();
  const T* w = k.weight.data();
  const T* s = k.scale.data();
  const T* d = k.diag.data();
  switch (op.method) {
    case LaplacianMethod::Uniform:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t, std::int32_t j, std::int64_t c) { return x[j * C + c]; },
          [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = sum * s[i] - x[i * C + c]; });
    case LaplacianMethod::Cot:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * x[j * C + c]; },
          [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = sum * s[i] - x[i * C + c]; });
    case LaplacianMethod::CotCurv:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * x[j * C + c]; },
          [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = (sum - d[i] * x[i * C + c]) * s[i]; });
  }
}

// W (S g), the transpose's sum over the same rows (W is symmetric), weighted by
// the neighbour's scale; for CotCurv minus D (S g) as well (the whole adjoint).
template <class T>
void laplacian_transpose(const Operator& op, const T* g, T* out, std::int64_t C) {
  const auto& k = op.coefficients<T>();
  const T* w = k.weight.data();
  const T* s = k.scale.data();
  const T* d = k.diag.data();
  switch (op.method) {
    case LaplacianMethod::Uniform:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t, std::int32_t j, std::int64_t c) { return g[j * C + c] * s[j]; },
          [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = sum; });
    case LaplacianMethod::Cot:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * (g[j * C + c] * s[j]); },
          [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = sum; });
    case LaplacianMethod::CotCurv:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * (g[j * C + c] * s[j]); },
          [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = sum - d[i] * (g[i * C + c] * s[i]); });
  }
}

}  // namespace

MeshLaplacian::MeshLaplacian(const Tensor& triangles, std::int64_t num_vertices)
    : method_(LaplacianMethod::Uniform), num_vertices_(num_vertices) {
  if (num_vertices < 0)
    throw ValueError("MeshLaplacian: argument 'num_vertices' must be >= 0, got " + std::to_string(num_vertices));
  detail::check_triangles(triangles, num_vertices, "MeshLaplacian");
  op_ = build(Tensor(), triangles, num_vertices, method_);
}

MeshLaplacian::MeshLaplacian(const Tensor& positions, const Tensor& triangles, LaplacianMethod method)
    : method_(method) {
  detail::check_mesh(positions, triangles, "MeshLaplacian");
  if (method != LaplacianMethod::Uniform && method != LaplacianMethod::Cot && method != LaplacianMethod::CotCurv)
    throw ValueError("MeshLaplacian: argument 'method' must be Uniform, Cot or CotCurv, got " +
                     std::to_string(int(method)));
  num_vertices_ = positions.size(0);
  op_ = build(positions, triangles, num_vertices_, method_);
}

Tensor MeshLaplacian::apply(const Tensor& x) const {
  const std::string name = "MeshLaplacian::apply";
  detail::check_float(x, name, "x");
  if (x.rank() != 2 || x.size(0) != num_vertices_)
    throw ShapeError(name + ": argument 'x' must have shape [V, C] with V = " + std::to_string(num_vertices_) +
                     ", got " + x.describe());
  const std::int64_t channels = x.size(1);
  Tensor out = Tensor::empty(x.shape(), x.dtype());
  dispatch_float(x.dtype(), name, [&](auto tag) {
    using T = decltype(tag);
    laplacian_forward(*op_, std::as_const(x).data<T>(), out.data<T>(), channels);
  });
  if (should_record({x})) {
    record("mesh_laplacian", {x}, {&out}, [op = op_, channels](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor part = Tensor::empty(g.shape(), g.dtype());
      dispatch_float(g.dtype(), "mesh_laplacian", [&](auto tag) {
        using T = decltype(tag);
        laplacian_transpose(*op, g.data<T>(), part.data<T>(), channels);
      });
      if (op->method == LaplacianMethod::CotCurv) return ctx.accumulate(0, part);
      // L^T g = W (S g) - g: -g first, then the sum (the order the fit
      // example's composite added its parts in, so its bits are kept).
      ctx.accumulate(0, neg(g));
      ctx.accumulate(0, part);
    });
  }
  return out;
}

Tensor MeshLaplacian::to_dense() const {
  const std::int64_t n = num_vertices_;
  Tensor m = Tensor::zeros({n, n}, DType::Float64);
  double* a = m.data<double>();
  const auto& k = op_->f64;
  const auto& rows = op_->rows;
  for (std::int64_t i = 0; i < n; ++i) {
    for (std::int64_t e = rows.start[i]; e < rows.start[i + 1]; ++e)
      a[i * n + rows.column[e]] += k.scale[i] * (k.weight.empty() ? 1.0 : k.weight[e]);
    a[i * n + i] -= method_ == LaplacianMethod::CotCurv ? k.scale[i] * k.diag[i] : 1.0;
  }
  return m;
}

}  // namespace gr
