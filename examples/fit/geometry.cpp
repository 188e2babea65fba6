// Vertex normals, built from gather / scatter_add, and the uniform Laplacian,
// one recorded sparse product with its adjoint; both differentiable with
// respect to the vertex positions.
#include "examples/fit/geometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "autodiff/error.h"
#include "autodiff/parallel.h"
#include "autodiff/tape.h"
#include "ops/ops.h"
#include "raster/procedural.h"

namespace fit {

using namespace gr;

namespace {

// Column k of an int32 [M, 3] triangle list as an [M] index tensor.
Tensor corner(const Tensor& triangles, int k) {
  return reshape(slice(triangles, 1, k, k + 1), {triangles.size(0)});
}

}  // namespace

Tensor vertex_normals(const Tensor& positions, const Tensor& triangles) {
  const Tensor i0 = corner(triangles, 0), i1 = corner(triangles, 1), i2 = corner(triangles, 2);
  const Tensor p0 = gather(positions, i0);
  const Tensor face = cross(gather(positions, i1) - p0, gather(positions, i2) - p0);  // [M, 3]
  const Tensor corners = concat({i0, i1, i2}, 0);                                     // [3M]
  const Tensor summed = scatter_add(concat({face, face, face}, 0), corners, positions.size(0));
  return normalize(summed);
}

UniformLaplacian::UniformLaplacian(const Tensor& triangles, std::int64_t num_vertices)
    : num_vertices_(num_vertices) {
  if (triangles.dtype() != DType::Int32 || triangles.rank() != 2 || triangles.size(1) != 3)
    throw ShapeError("UniformLaplacian: triangles must be int32 [M, 3], got " + triangles.describe());
  // Each vertex's distinct edge neighbours, ascending (works for open and closed meshes).
  std::vector<std::vector<std::int32_t>> lists(static_cast<std::size_t>(num_vertices));
  const std::int32_t* t = std::as_const(triangles).data<std::int32_t>();
  for (std::int64_t k = 0; k < triangles.numel(); ++k)
    if (t[k] < 0 || t[k] >= num_vertices)
      throw IndexError("UniformLaplacian: triangle index " + std::to_string(t[k]) + " is outside [0, " +
                       std::to_string(num_vertices) + ")");
  for (std::int64_t f = 0; f < triangles.size(0); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t a = t[3 * f + k], b = t[3 * f + (k + 1) % 3];
      if (a == b) continue;
      lists[a].push_back(b);
      lists[b].push_back(a);
    }
  auto adjacency = std::make_shared<Adjacency>();
  adjacency->start.push_back(0);
  for (auto& list : lists) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    adjacency->neighbours.insert(adjacency->neighbours.end(), list.begin(), list.end());
    adjacency->start.push_back(static_cast<std::int64_t>(adjacency->neighbours.size()));
    adjacency->inv_degree.push_back(list.empty() ? 0.0f : float(1.0 / double(list.size())));
  }
  adjacency_ = std::move(adjacency);
}

namespace {

using Adjacency = UniformLaplacian::Adjacency;

// Rows per parallel chunk: each row reads about (mean degree + 1) C values,
// and a chunk reads 4 elementwise grains' worth. Measured on 2 threads: the
// fit's 2562-point product (13 us) runs faster inline than split (launch and
// wake-up cost more than half of it); 10242 points split 54 -> 38 us.
std::int64_t laplacian_grain(const Adjacency& a, std::int64_t channels) {
  const std::int64_t rows = std::max<std::int64_t>(1, std::int64_t(a.inv_degree.size()));
  const std::int64_t reads = (std::int64_t(a.neighbours.size()) / rows + 1) * std::max<std::int64_t>(1, channels);
  return std::max<std::int64_t>(1, 4 * kElementwiseGrain / reads);
}

// For every vertex i, in parallel over rows, and channel c < C:
//   emit(i, c, sum_{j in N(i)} term(j, c)),
// each sum from 0 in ascending j. C = 1..4 get accumulators of fixed length
// (one pass over the neighbour list), other C one pass per channel.
template <class T, class Term, class Emit>
void neighbour_sums(const Adjacency& a, std::int64_t channels, Term term, Emit emit) {
  const std::int64_t* start = a.start.data();
  const std::int32_t* nb = a.neighbours.data();
  auto rows = [&](auto fixed, std::int64_t lo, std::int64_t hi) {
    constexpr int K = decltype(fixed)::value;
    for (std::int64_t i = lo; i < hi; ++i) {
      T s[K] = {};
      for (std::int64_t e = start[i]; e < start[i + 1]; ++e)
        for (int c = 0; c < K; ++c) s[c] += term(nb[e], c);
      for (int c = 0; c < K; ++c) emit(i, c, s[c]);
    }
  };
  const std::int64_t n = std::int64_t(a.inv_degree.size());
  parallel_for(0, n, laplacian_grain(a, channels), [&](std::int64_t lo, std::int64_t hi) {
    switch (channels) {
      case 1: return rows(std::integral_constant<int, 1>(), lo, hi);
      case 2: return rows(std::integral_constant<int, 2>(), lo, hi);
      case 3: return rows(std::integral_constant<int, 3>(), lo, hi);
      case 4: return rows(std::integral_constant<int, 4>(), lo, hi);
      default:
        for (std::int64_t i = lo; i < hi; ++i)
          for (std::int64_t c = 0; c < channels; ++c) {
            T s = 0;
            for (std::int64_t e = start[i]; e < start[i + 1]; ++e) s += term(nb[e], c);
            emit(i, c, s);
          }
    }
  });
}

// L(p)[i, c] = p[i, c] - (sum_{j in N(i)} p[j, c]) w_i with w_i = 1/deg_i: the
// sum, then one product and one difference in T (the order gather +
// scatter_add + mul + sub had, so the bits are theirs).
template <class T>
void laplacian_forward(const Adjacency& a, const T* p, T* out, std::int64_t channels) {
  neighbour_sums<T>(
      a, channels, [=](std::int32_t j, std::int64_t c) { return p[j * channels + c]; },
      [&](std::int64_t i, std::int64_t c, T sum) {
        out[i * channels + c] = p[i * channels + c] - sum * T(a.inv_degree[i]);
      });
}

// The second term of L^T g: out[j, c] = sum_{i in N(j)} -(g[i, c] w_i), over
// the transpose's rows. N is symmetric (i in N(j) iff j in N(i)), so the
// transpose has the same lists, weighted by the neighbour's w_i; summed in
// ascending i from 0, as the gather adjoint summed sub's -g times mul's w.
template <class T>
void laplacian_transpose_part(const Adjacency& a, const T* g, T* out, std::int64_t channels) {
  const float* w = a.inv_degree.data();
  neighbour_sums<T>(
      a, channels, [=](std::int32_t i, std::int64_t c) { return -(g[i * channels + c] * T(w[i])); },
      [=](std::int64_t j, std::int64_t c, T sum) { out[j * channels + c] = sum; });
}

}  // namespace

Tensor UniformLaplacian::apply(const Tensor& positions) const {
  if (!positions.defined() || positions.rank() != 2 || positions.size(0) != num_vertices_)
    throw ShapeError("UniformLaplacian::apply: positions must be [" + std::to_string(num_vertices_) + ", C], got " +
                     (positions.defined() ? positions.describe() : std::string("an undefined tensor")));
  const std::int64_t channels = positions.size(1);
  Tensor out = Tensor::empty(positions.shape(), positions.dtype());
  dispatch_float(positions.dtype(), "UniformLaplacian::apply", [&](auto tag) {
    using T = decltype(tag);
    laplacian_forward(*adjacency_, std::as_const(positions).data<T>(), out.data<T>(), channels);
  });
  if (should_record({positions})) {
    record("uniform_laplacian", {positions}, {&out}, [adjacency = adjacency_, channels](AdjointContext& ctx) {
      const Tensor& g = ctx.grad_output();
      if (!g.defined()) return;
      // dL/dp = L^T g = g - N^T (g w), added in that order (as sub's and then
      // gather's adjoints added their parts).
      Tensor part = Tensor::empty(g.shape(), g.dtype());
      dispatch_float(g.dtype(), "uniform_laplacian", [&](auto tag) {
        using T = decltype(tag);
        laplacian_transpose_part(*adjacency, g.data<T>(), part.data<T>(), channels);
      });
      ctx.accumulate(0, g);
      ctx.accumulate(0, part);
    });
  }
  return out;
}

Tensor UniformLaplacian::penalty(const Tensor& positions) const {
  const Tensor l = apply(positions);
  return mean(sum(l * l, -1));
}

Tensor SurfaceMesh::to_render(const Tensor& per_point) const { return gather(per_point, render_to_point); }

namespace {

// Fills the derived fields (antialias topology) once the index arrays are set.
void finish_surface(SurfaceMesh& s) {
  if (s.triangles.size(0) == 0) throw ValueError("fit: the mesh has no non-degenerate triangle");
  s.topology = antialias_topology(s.triangles, s.to_render(s.positions));
}

}  // namespace

SurfaceMesh make_surface(const raster::Mesh& mesh) {
  const float* p = mesh.positions.data<float>();
  std::map<std::array<float, 3>, std::int32_t> index_of;
  std::vector<float> points;
  std::vector<std::int32_t> to_point(static_cast<std::size_t>(mesh.num_vertices()));
  for (std::int64_t i = 0; i < mesh.num_vertices(); ++i) {
    const std::array<float, 3> key{p[3 * i], p[3 * i + 1], p[3 * i + 2]};
    auto [it, inserted] = index_of.emplace(key, static_cast<std::int32_t>(index_of.size()));
    if (inserted) points.insert(points.end(), key.begin(), key.end());
    to_point[i] = it->second;
  }
  std::vector<std::int32_t> tris, point_tris;
  const std::int32_t* t = mesh.triangles.data<std::int32_t>();
  for (std::int64_t f = 0; f < mesh.num_triangles(); ++f) {
    const std::int32_t a = to_point[t[3 * f]], b = to_point[t[3 * f + 1]], c = to_point[t[3 * f + 2]];
    if (a == b || b == c || a == c) continue;
    tris.insert(tris.end(), {t[3 * f], t[3 * f + 1], t[3 * f + 2]});
    point_tris.insert(point_tris.end(), {a, b, c});
  }
  SurfaceMesh s;
  const std::int64_t m = std::int64_t(tris.size() / 3);
  s.positions = Tensor::from_vector(points, {std::int64_t(points.size() / 3), 3});
  s.triangles = Tensor::from_vector(tris, {m, 3});
  s.point_triangles = Tensor::from_vector(point_tris, {m, 3});
  s.render_to_point = Tensor::from_vector(to_point, {mesh.num_vertices()});
  if (mesh.has_uvs()) s.uvs = mesh.uvs;
  finish_surface(s);
  return s;
}

SurfaceMesh sphere_surface(int subdivisions, double radius) {
  constexpr double kPi = 3.14159265358979323846;
  const raster::Mesh ico = raster::make_icosphere(subdivisions, 1.0f);
  const std::int64_t n = ico.num_vertices();
  const float* p = ico.positions.data<float>();
  std::vector<float> points(static_cast<std::size_t>(3 * n)), uvs;
  std::vector<std::int32_t> to_point;
  for (std::int64_t i = 0; i < n; ++i) {
    const double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2], r = std::sqrt(x * x + y * y + z * z);
    for (int k = 0; k < 3; ++k) points[3 * i + k] = float(radius * p[3 * i + k] / r);
    uvs.push_back(float(0.5 + std::atan2(x, z) / (2 * kPi)));
    uvs.push_back(float(0.5 + std::asin(std::clamp(y / r, -1.0, 1.0)) / kPi));
    to_point.push_back(std::int32_t(i));
  }
  // Seam: corners of a straddling triangle with u < 0.5 use a copy at u + 1.
  std::map<std::int32_t, std::int32_t> shifted;
  std::vector<std::int32_t> tris;
  const std::int32_t* t = ico.triangles.data<std::int32_t>();
  for (std::int64_t f = 0; f < ico.num_triangles(); ++f) {
    std::array<std::int32_t, 3> c{t[3 * f], t[3 * f + 1], t[3 * f + 2]};
    double lo = 2, hi = -1;
    for (std::int32_t v : c) lo = std::min(lo, double(uvs[2 * v])), hi = std::max(hi, double(uvs[2 * v]));
    if (hi - lo > 0.5)
      for (std::int32_t& v : c) {
        if (uvs[2 * v] >= 0.5) continue;
        auto [it, inserted] = shifted.emplace(v, std::int32_t(to_point.size()));
        if (inserted) {
          uvs.push_back(uvs[2 * v] + 1.0f);
          uvs.push_back(uvs[2 * v + 1]);
          to_point.push_back(v);
        }
        v = it->second;
      }
    tris.insert(tris.end(), c.begin(), c.end());
  }
  SurfaceMesh s;
  s.positions = Tensor::from_vector(points, {n, 3});
  s.point_triangles = ico.triangles;
  s.triangles = Tensor::from_vector(tris, {ico.num_triangles(), 3});
  s.render_to_point = Tensor::from_vector(to_point, {std::int64_t(to_point.size())});
  s.uvs = Tensor::from_vector(uvs, {std::int64_t(to_point.size()), 2});
  finish_surface(s);
  return s;
}

}  // namespace fit
