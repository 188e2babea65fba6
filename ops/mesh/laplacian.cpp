// Mesh Laplacians: construction of the rows, weights and scales (serial, in a
// fixed order), and the sparse product and its adjoint (one recorded op, in
// parallel over rows through detail::row_sums).
#include "ops/mesh/laplacian.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "autodiff/base/dtype.h"
#include "autodiff/base/parallel.h"
#include "autodiff/base/error.h"
#include "autodiff/base/memory.h"
#include "autodiff/tape.h"
#include "ops/check.h"
#include "ops/tensor/elementwise.h"
#include "ops/mesh/lanes.h"
#include "ops/mesh/row_sums.h"
#include "ops/mesh/topology.h"
#include "ops/tensor/small_count.h"

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

// q = S (a g) (a = 1: S g), each vertex's scale applied once: the products
// the transpose's terms read, the same float products as scaling per term.
template <class T, class Channels>
void scale_rows(const T* s, T a, const T* g, T* q, std::int64_t rows, Channels C) {
  parallel_for(0, rows, std::max<std::int64_t>(1, kElementwiseGrain / std::max<std::int64_t>(1, C)),
               [=](std::int64_t lo, std::int64_t hi) {
                 for (std::int64_t i = lo; i < hi; ++i) {
                   const T si = s[i];
                   for (std::int64_t c = 0; c < C; ++c) q[i * C + c] = (a * g[i * C + c]) * si;  // 1 g = g
                 }
               });
}

// W q, the transpose's sum over the same rows (W is symmetric) of q = S g,
// passed to emit(i, c, sum) (Cot, CotCurv: each term w_e q_j).
template <class T, class Channels, class Emit>
void weighted_rows(const Operator& op, const T* q, Channels C, Emit emit) {
  const T* w = op.coefficients<T>().weight.data();
  if (op.method == LaplacianMethod::Uniform)
    return detail::row_sums<T>(op.rows, C, [=](std::int64_t, std::int32_t j, std::int64_t c) { return q[j * C + c]; },
                               emit);
  return detail::row_sums<T>(
      op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * q[j * C + c]; }, emit);
}

// W (S g); for CotCurv minus D (S g) as well (the whole adjoint).
template <class T>
void laplacian_transpose(const Operator& op, const T* g, T* out, std::int64_t C) {
  const auto& k = op.coefficients<T>();
  const std::int64_t V = op.rows.rows();
  Tensor scaled = Tensor::empty({V, C}, dtype_of<T>::value);  // scratch, every entry written
  T* const q = scaled.data<T>();
  detail::with_small_count(C, [&](auto channels) { scale_rows(k.scale.data(), T(1), g, q, V, channels); });
  if (op.method == LaplacianMethod::CotCurv) {
    const T* d = k.diag.data();
    return weighted_rows<T>(op, q, C, [=](std::int64_t i, std::int64_t c, T sum) {
      out[i * C + c] = sum - d[i] * q[i * C + c];
    });
  }
  weighted_rows<T>(op, q, C, [=](std::int64_t i, std::int64_t c, T sum) { out[i * C + c] = sum; });
}

// One smoothing pass y = x + a (L x), in T with the composite's roundings
// (L x as laplacian_forward, then a times it, then the sum).
template <class T>
void smooth_forward(const Operator& op, T a, const T* x, T* y, std::int64_t C) {
  const auto& k = op.coefficients<T>();
  const T* w = k.weight.data();
  const T* s = k.scale.data();
  const T* d = k.diag.data();
  switch (op.method) {
    case LaplacianMethod::Uniform:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t, std::int32_t j, std::int64_t c) { return x[j * C + c]; },
          [=](std::int64_t i, std::int64_t c, T sum) { y[i * C + c] = x[i * C + c] + a * (sum * s[i] - x[i * C + c]); });
    case LaplacianMethod::Cot:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * x[j * C + c]; },
          [=](std::int64_t i, std::int64_t c, T sum) { y[i * C + c] = x[i * C + c] + a * (sum * s[i] - x[i * C + c]); });
    case LaplacianMethod::CotCurv:
      return detail::row_sums<T>(
          op.rows, C, [=](std::int64_t e, std::int32_t j, std::int64_t c) { return w[e] * x[j * C + c]; },
          [=](std::int64_t i, std::int64_t c, T sum) {
            y[i * C + c] = x[i * C + c] + a * ((sum - d[i] * x[i * C + c]) * s[i]);
          });
  }
}

// Its adjoint for g = dL/dy, into gx (overwritten): gx = g + L^T (a g), with
// h = a g and the composite's order of accumulation: for Uniform and Cot
// (g - h) + W (S h) (g, then apply's -h, then its sum), for CotCurv
// g + (W (S h) - D (S h)). q = S h (scale_rows); q_next, if given, gets the
// next pass's S (a gx).
template <class T>
void smooth_backward(const Operator& op, T a, const T* g, const T* q, T* gx, T* q_next, std::int64_t C) {
  const auto& k = op.coefficients<T>();
  const T* s = k.scale.data();
  auto next = [=](std::int64_t i, std::int64_t c, T value) {
    gx[i * C + c] = value;
    if (q_next) q_next[i * C + c] = (a * value) * s[i];
  };
  if (op.method == LaplacianMethod::CotCurv) {
    const T* d = k.diag.data();
    return weighted_rows<T>(op, q, C, [=](std::int64_t i, std::int64_t c, T sum) {
      next(i, c, g[i * C + c] + (sum - d[i] * q[i * C + c]));
    });
  }
  weighted_rows<T>(op, q, C, [=](std::int64_t i, std::int64_t c, T sum) {
    next(i, c, (g[i * C + c] + -(a * g[i * C + c])) + sum);
  });
}

// Three channels (positions, normals) padded to four lanes (ops/mesh/lanes.h):
// one vector add per neighbour instead of three scalar ones, with the bits of
// the one-channel-at-a-time kernels above.
template <class T>
using Lanes = detail::Lanes4<T>;

// rows [V, 3] -> [V, 4] (lane 3 zero).
template <class T>
void pad_rows(const T* in, Lanes<T>* out, std::int64_t rows) {
  parallel_for(0, rows, kElementwiseGrain / 4, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) out[i] = Lanes<T>{in[3 * i], in[3 * i + 1], in[3 * i + 2], T(0)};
  });
}

// emit(i, sum of row i's terms) with lanes; the terms as weighted_rows' (w_e v_j, or v_j for Uniform).
template <class T, class Emit>
void lane_row_sums(const Operator& op, const Lanes<T>* v, Emit emit) {
  const detail::VertexRows& r = op.rows;
  const std::int64_t* start = r.start.data();
  const std::int32_t* col = r.column.data();
  const T* w = op.coefficients<T>().weight.data();
  const bool weighted = op.method != LaplacianMethod::Uniform;
  parallel_for(0, r.rows(), detail::row_sum_grain(r, 3), [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      Lanes<T> sum = {};
      if (weighted)
        for (std::int64_t e = start[i]; e < start[i + 1]; ++e) sum += w[e] * v[col[e]];
      else
        for (std::int64_t e = start[i]; e < start[i + 1]; ++e) sum += v[col[e]];
      emit(i, sum);
    }
  });
}

// Stores row i's lanes into padded rows, or its three channels into [V, 3].
template <class T>
struct LaneOut {
  Lanes<T>* padded = nullptr;
  T* rows3 = nullptr;
  void store(std::int64_t i, const Lanes<T>& v) const {
    if (padded) {
      padded[i] = v;
    } else {
      rows3[3 * i] = v[0], rows3[3 * i + 1] = v[1], rows3[3 * i + 2] = v[2];
    }
  }
};

// smooth_forward with lanes: x padded, y padded or [V, 3].
template <class T>
void smooth_forward_lanes(const Operator& op, T a, const Lanes<T>* x, LaneOut<T> y) {
  const auto& k = op.coefficients<T>();
  const T* s = k.scale.data();
  const T* d = k.diag.data();
  if (op.method == LaplacianMethod::CotCurv)
    return lane_row_sums<T>(op, x, [=](std::int64_t i, const Lanes<T>& sum) {
      y.store(i, x[i] + a * ((sum - d[i] * x[i]) * s[i]));
    });
  lane_row_sums<T>(op, x, [=](std::int64_t i, const Lanes<T>& sum) { y.store(i, x[i] + a * (sum * s[i] - x[i])); });
}

// smooth_backward with lanes: g, q padded; gx padded or [V, 3]; q_next as there.
template <class T>
void smooth_backward_lanes(const Operator& op, T a, const Lanes<T>* g, const Lanes<T>* q, LaneOut<T> gx,
                           Lanes<T>* q_next) {
  const auto& k = op.coefficients<T>();
  const T* s = k.scale.data();
  auto next = [=](std::int64_t i, const Lanes<T>& value) {
    gx.store(i, value);
    if (q_next) q_next[i] = (a * value) * s[i];
  };
  if (op.method == LaplacianMethod::CotCurv) {
    const T* d = k.diag.data();
    return lane_row_sums<T>(op, q, [=](std::int64_t i, const Lanes<T>& sum) { next(i, g[i] + (sum - d[i] * q[i])); });
  }
  lane_row_sums<T>(op, q, [=](std::int64_t i, const Lanes<T>& sum) { next(i, (g[i] + -(a * g[i])) + sum); });
}

// (I + a L)^passes on [V, 3]: x in, out written (passes >= 1).
template <class T>
void smooth_lanes(const Operator& op, T a, const T* x, T* out, int passes) {
  const std::int64_t V = op.rows.rows();
  Tensor buffers = Tensor::empty({3, V, 4}, dtype_of<T>::value);  // the padded input and two ping-pong rows
  Lanes<T>* const b = reinterpret_cast<Lanes<T>*>(buffers.data<T>());
  Lanes<T>* const in = b;
  Lanes<T>* const pong[2] = {b + V, b + 2 * V};
  pad_rows(x, in, V);
  const Lanes<T>* src = in;
  for (int k = 0; k < passes; ++k) {
    const bool last = k + 1 == passes;
    smooth_forward_lanes<T>(op, a, src, last ? LaneOut<T>{nullptr, out} : LaneOut<T>{pong[k % 2], nullptr});
    src = pong[k % 2];
  }
}

// Its adjoint: g [V, 3] in, grad [V, 3] written.
template <class T>
void smooth_lanes_adjoint(const Operator& op, T a, const T* g, T* grad, int passes) {
  const std::int64_t V = op.rows.rows();
  Tensor buffers = Tensor::empty({5, V, 4}, dtype_of<T>::value);  // g padded, two ping-pong g, two q
  Lanes<T>* const b = reinterpret_cast<Lanes<T>*>(buffers.data<T>());
  Lanes<T>* const g_pad = b;
  Lanes<T>* const pong[2] = {b + V, b + 2 * V};
  Lanes<T>* const q[2] = {b + 3 * V, b + 4 * V};
  pad_rows(g, g_pad, V);
  const T* s = op.coefficients<T>().scale.data();
  parallel_for(0, V, kElementwiseGrain / 4, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) q[0][i] = (a * g_pad[i]) * s[i];
  });
  const Lanes<T>* src = g_pad;
  for (int k = 0; k < passes; ++k) {
    const bool last = k + 1 == passes;
    smooth_backward_lanes<T>(op, a, src, q[k % 2], last ? LaneOut<T>{nullptr, grad} : LaneOut<T>{pong[k % 2], nullptr},
                             last ? nullptr : q[(k + 1) % 2]);
    src = pong[k % 2];
  }
}

}  // namespace

MeshLaplacian::MeshLaplacian(const Tensor& triangles, std::int64_t num_vertices)
    : method_(LaplacianMethod::Uniform), num_vertices_(num_vertices) {
  if (num_vertices < 0)
    throw ValueError("MeshLaplacian: argument 'num_vertices' must be >= 0, got " + std::to_string(num_vertices));
  detail::check_triangles(triangles, num_vertices, "MeshLaplacian");
  // The rows and coefficients take about 64 bytes a vertex, used or not (no
  // tensor of num_vertices rows exists yet to have been counted): a bare count
  // such as 2^31 must be a MemoryError, not 16 GB of zeros and an OOM kill.
  constexpr std::size_t kBytesPerVertex = 64;
  const std::size_t n = static_cast<std::size_t>(num_vertices);
  check_memory_request(n > SIZE_MAX / kBytesPerVertex ? SIZE_MAX : n * kBytesPerVertex,
                       "MeshLaplacian: the tables of " + std::to_string(num_vertices) + " vertices");
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

Tensor MeshLaplacian::smooth(const Tensor& x, int passes, double step) const {
  const std::string name = "MeshLaplacian::smooth";
  detail::check_float(x, name, "x");
  if (x.rank() != 2 || x.size(0) != num_vertices_)
    throw ShapeError(name + ": argument 'x' must have shape [V, C] with V = " + std::to_string(num_vertices_) +
                     ", got " + x.describe());
  if (passes < 0) throw ValueError(name + ": argument 'passes' must be >= 0, got " + std::to_string(passes));
  if (!std::isfinite(step)) throw ValueError(name + ": argument 'step' must be finite, got " + std::to_string(step));
  if (passes == 0) return x;
  const std::int64_t channels = x.size(1);
  // Ping-pong: pass k reads one buffer and writes the other; the last one written is the result.
  Tensor out = Tensor::empty(x.shape(), x.dtype());
  dispatch_float(x.dtype(), name, [&](auto tag) {
    using T = decltype(tag);
    const T a = static_cast<T>(step);  // the composite's scalar, in x's dtype
    if (channels == 3) return smooth_lanes(*op_, a, std::as_const(x).data<T>(), out.data<T>(), passes);
    Tensor other = passes > 1 ? Tensor::empty(x.shape(), x.dtype()) : out;  // unused for one pass
    T* dst[2] = {(passes % 2 ? out : other).data<T>(), (passes % 2 ? other : out).data<T>()};
    const T* src = std::as_const(x).data<T>();
    for (int k = 0; k < passes; ++k) {
      smooth_forward(*op_, a, src, dst[k % 2], channels);
      src = dst[k % 2];
    }
  });
  if (should_record({x})) {
    record("mesh_laplacian_smooth", {x}, {&out}, [op = op_, channels, passes, step](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      Tensor grad = Tensor::empty(g.shape(), g.dtype());
      dispatch_float(g.dtype(), "mesh_laplacian_smooth", [&](auto tag) {
        using T = decltype(tag);
        const T a = static_cast<T>(step);
        if (channels == 3) return smooth_lanes_adjoint(*op, a, g.data<T>(), grad.data<T>(), passes);
        Tensor other = passes > 1 ? Tensor::empty(g.shape(), g.dtype()) : grad;
        Tensor q[2] = {Tensor::empty(g.shape(), g.dtype()), Tensor::empty(g.shape(), g.dtype())};  // S (a g) per pass
        // The passes in reverse; the last one writes grad.
        T* dst[2] = {(passes % 2 ? grad : other).data<T>(), (passes % 2 ? other : grad).data<T>()};
        const T* src = g.data<T>();
        detail::with_small_count(channels, [&](auto C) {  // C constant: the row's loop unrolled
          scale_rows(op->coefficients<T>().scale.data(), a, src, q[0].data<T>(), op->rows.rows(), C);
        });
        for (int k = 0; k < passes; ++k) {
          T* q_next = k + 1 < passes ? q[(k + 1) % 2].data<T>() : nullptr;
          smooth_backward(*op, a, src, std::as_const(q[k % 2]).data<T>(), dst[k % 2], q_next, channels);
          src = dst[k % 2];
        }
      });
      ctx.accumulate(0, grad);
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
