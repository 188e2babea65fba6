// The large-steps matrix M = a I + b (D - A): its rows for the product, and
// its sparse Cholesky factor (Eigen's SimplicialLLT, serial, float64) for the
// solve. Both ops are recorded with their adjoints: M is symmetric, so the
// adjoint of the product is the same product and that of the solve the same
// solve, of the incoming gradient.
#include "ops/mesh/large_steps.h"

#include <cmath>
#include <string>
#include <utility>
#include <vector>

// Eigen is private to the library (docs/decisions.md): renamed here as in
// ops/tensor/linalg.cpp, so the instantiations this file makes are not the weak
// Eigen::... symbols of a consumer's own Eigen code. No header of ours
// includes Eigen.
#define Eigen gr_private_eigen
#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "autodiff/base/dtype.h"
#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/mesh/row_sums.h"
#include "ops/mesh/topology.h"

namespace gr {

struct LargeSteps::Factor {
  detail::VertexRows rows;  // the graph's neighbour lists (no self edges)
  double a = 1, b = 0;      // M = a I + b (D - A)
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt;
};

namespace {

using Factor = LargeSteps::Factor;

// out = M v for v [V, C]: out_i = a v_i + b (deg_i v_i - sum_{j in N(i)} v_j).
template <class T>
void multiply(const Factor& f, const T* v, T* out, std::int64_t C) {
  const T a = T(f.a), b = T(f.b);
  const std::int64_t* start = f.rows.start.data();
  detail::row_sums<T>(
      f.rows, C, [=](std::int64_t, std::int32_t j, std::int64_t c) { return v[j * C + c]; },
      [=](std::int64_t i, std::int64_t c, T sum) {
        const T x = v[i * C + c];
        out[i * C + c] = a * x + b * (T(start[i + 1] - start[i]) * x - sum);
      });
}

// out = M^-1 v for v [V, C], each column solved in float64.
template <class T>
void solve(const Factor& f, const T* v, T* out, std::int64_t rows, std::int64_t C) {
  Eigen::MatrixXd rhs(rows, C);
  for (std::int64_t i = 0; i < rows; ++i)
    for (std::int64_t c = 0; c < C; ++c) rhs(i, c) = double(v[i * C + c]);
  const Eigen::MatrixXd x = f.llt.solve(rhs);
  for (std::int64_t i = 0; i < rows; ++i)
    for (std::int64_t c = 0; c < C; ++c) out[i * C + c] = T(x(i, c));
}

void check_values(const Tensor& t, std::int64_t n, const std::string& op, const char* name) {
  detail::check_float(t, op, name);
  if (t.rank() != 2 || t.size(0) != n)
    throw ShapeError(op + ": argument '" + name + "' must have shape [V, C] with V = " + std::to_string(n) +
                     ", got " + t.describe());
  detail::check_finite(t, op, name);
}

}  // namespace

LargeSteps::LargeSteps(const Tensor& positions, const Tensor& triangles, double lambda)
    : LargeSteps(positions, triangles, 1.0, lambda, "LargeSteps") {}

LargeSteps LargeSteps::with_alpha(const Tensor& positions, const Tensor& triangles, double alpha) {
  if (!(alpha >= 0 && alpha < 1))
    throw ValueError("LargeSteps::with_alpha: argument 'alpha' must be in [0, 1), got " + std::to_string(alpha));
  return LargeSteps(positions, triangles, 1.0 - alpha, alpha, "LargeSteps::with_alpha");
}

LargeSteps::LargeSteps(const Tensor& positions, const Tensor& triangles, double diag_weight, double lap_weight,
                       const char* op)
    : diag_weight_(diag_weight), lap_weight_(lap_weight) {
  detail::check_mesh(positions, triangles, op);
  if (!(lap_weight >= 0) || !std::isfinite(lap_weight))
    throw ValueError(std::string(op) + ": argument 'lambda' must be >= 0 and finite, got " +
                     std::to_string(lap_weight));
  num_vertices_ = positions.size(0);
  factor_ = guard_allocation(op, [&] {
    auto f = std::make_shared<Factor>();
    f->a = diag_weight;
    f->b = lap_weight;
    f->rows = detail::edge_rows(detail::mesh_edges(triangles, num_vertices_), num_vertices_, /*self_edges=*/false);
    // M's entries: a + b deg_i on the diagonal, -b per neighbour.
    std::vector<Eigen::Triplet<double>> entries;
    entries.reserve(f->rows.column.size() + static_cast<std::size_t>(num_vertices_));
    for (std::int64_t i = 0; i < num_vertices_; ++i) {
      const std::int64_t degree = f->rows.start[i + 1] - f->rows.start[i];
      entries.emplace_back(int(i), int(i), diag_weight + lap_weight * double(degree));
      for (std::int64_t e = f->rows.start[i]; e < f->rows.start[i + 1]; ++e)
        entries.emplace_back(int(i), int(f->rows.column[e]), -lap_weight);
    }
    const auto n = static_cast<Eigen::Index>(num_vertices_);
    Eigen::SparseMatrix<double> m(n, n);
    m.setFromTriplets(entries.begin(), entries.end());
    f->llt.compute(m);
    if (f->llt.info() != Eigen::Success)  // cannot happen for these matrices; kept as a guard
      throw ValueError(std::string(op) + ": the matrix is not positive definite");
    return std::shared_ptr<const Factor>(std::move(f));
  });
}

Tensor LargeSteps::to_differential(const Tensor& x) const {
  const std::string op = "LargeSteps::to_differential";
  check_values(x, num_vertices_, op, "x");
  const std::int64_t channels = x.size(1);
  Tensor out = Tensor::empty(x.shape(), x.dtype());
  dispatch_float(x.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    multiply(*factor_, std::as_const(x).data<T>(), out.data<T>(), channels);
  });
  if (should_record({x})) {
    record("large_steps_to_differential", {x}, {&out}, [f = factor_, channels](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor grad = Tensor::empty(g.shape(), g.dtype());
      dispatch_float(g.dtype(), "large_steps_to_differential", [&](auto tag) {
        using T = decltype(tag);
        multiply(*f, g.data<T>(), grad.data<T>(), channels);
      });
      ctx.accumulate(0, grad);
    });
  }
  return out;
}

Tensor LargeSteps::from_differential(const Tensor& u) const {
  const std::string op = "LargeSteps::from_differential";
  check_values(u, num_vertices_, op, "u");
  const std::int64_t channels = u.size(1), rows = num_vertices_;
  Tensor out = Tensor::empty(u.shape(), u.dtype());
  dispatch_float(u.dtype(), op, [&](auto tag) {
    using T = decltype(tag);
    solve(*factor_, std::as_const(u).data<T>(), out.data<T>(), rows, channels);
  });
  if (should_record({u})) {
    record("large_steps_from_differential", {u}, {&out}, [f = factor_, rows, channels](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor grad = Tensor::empty(g.shape(), g.dtype());
      dispatch_float(g.dtype(), "large_steps_from_differential", [&](auto tag) {
        using T = decltype(tag);
        solve(*f, g.data<T>(), grad.data<T>(), rows, channels);
      });
      ctx.accumulate(0, grad);
    });
  }
  return out;
}

Tensor LargeSteps::matrix() const {
  const std::int64_t n = num_vertices_;
  Tensor m = Tensor::zeros({n, n}, DType::Float64);
  double* a = m.data<double>();
  const auto& rows = factor_->rows;
  for (std::int64_t i = 0; i < n; ++i) {
    a[i * n + i] = diag_weight_ + lap_weight_ * double(rows.start[i + 1] - rows.start[i]);
    for (std::int64_t e = rows.start[i]; e < rows.start[i + 1]; ++e) a[i * n + rows.column[e]] = -lap_weight_;
  }
  return m;
}

}  // namespace gr
