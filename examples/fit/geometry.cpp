// The fit's mesh: welding a loaded mesh's points, the icosphere with uvs, and
// the Laplacian smoothness penalty.
#include "examples/fit/geometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"
#include "ops/ops.h"
#include "raster/procedural.h"

namespace fit {

using namespace gr;

Tensor laplacian_penalty(const MeshLaplacian& laplacian, const Tensor& positions) {
  const Tensor l = laplacian.apply(positions);
  return mean(sum(l * l, -1));
}

Tensor penalty_gradient(const MeshLaplacian& laplacian, const Tensor& positions, double weight) {
  ScopedTape tape;
  Tensor x = positions.detach().set_requires_grad();
  backward(weight * laplacian_penalty(laplacian, x));
  return x.grad();
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
