// Procedural mesh generators. Each one fills plain arrays through a small
// builder and converts them to a Mesh at the end. Seam vertices reuse the
// angle of their twin (index modulo the segment count) so duplicated vertices
// get bit-identical positions and the shapes stay watertight when welded.
#include "raster/procedural.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"

namespace gr::raster {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Builder {
  std::vector<float> pos, nrm, uv;
  std::vector<std::int32_t> tri;

  std::int32_t vertex(const float p[3], const float n[3], float u, float v) {
    pos.insert(pos.end(), p, p + 3);
    nrm.insert(nrm.end(), n, n + 3);
    uv.push_back(u);
    uv.push_back(v);
    return static_cast<std::int32_t>(pos.size() / 3 - 1);
  }
  void triangle(std::int32_t a, std::int32_t b, std::int32_t c) {
    tri.push_back(a);
    tri.push_back(b);
    tri.push_back(c);
  }
  Mesh mesh() const {
    const auto n = static_cast<std::int64_t>(pos.size() / 3);
    Mesh m;
    m.positions = Tensor::from_vector(pos, {n, 3});
    m.triangles = Tensor::from_vector(tri, {static_cast<std::int64_t>(tri.size() / 3), 3});
    if (!nrm.empty()) m.normals = Tensor::from_vector(nrm, {n, 3});
    if (!uv.empty()) m.uvs = Tensor::from_vector(uv, {n, 2});
    return m;
  }
};

void require(bool ok, const std::string& msg) {
  if (!ok) throw ValueError(msg);
}

bool positive_finite(float x) { return std::isfinite(x) && x > 0; }

// Requires a vertex count that int32 triangle indices can address.
void require_addressable(const char* what, double vertices) {
  require(vertices < 2147483647.0,
          std::string(what) + ": too many vertices for int32 indices");
}

// 1-to-4 subdivision of a builder in place; midpoints keyed by edge.
void subdivide_builder(Builder& b) {
  const bool has_n = !b.nrm.empty(), has_uv = !b.uv.empty();
  std::unordered_map<std::uint64_t, std::int32_t> mid;
  mid.reserve(b.tri.size());
  auto midpoint = [&](std::int32_t i, std::int32_t j) {
    const std::uint64_t key = (static_cast<std::uint64_t>(std::min(i, j)) << 32) |
                              static_cast<std::uint32_t>(std::max(i, j));
    auto [it, inserted] = mid.emplace(key, 0);
    if (!inserted) return it->second;
    // a + b == b + a in floating point, so both triangles of an edge agree.
    for (int k = 0; k < 3; ++k) b.pos.push_back((b.pos[3 * i + k] + b.pos[3 * j + k]) * 0.5f);
    if (has_n) {
      float n[3], len2 = 0;
      for (int k = 0; k < 3; ++k) {
        n[k] = b.nrm[3 * i + k] + b.nrm[3 * j + k];
        len2 += n[k] * n[k];
      }
      const float s = len2 > 0 ? 1.0f / std::sqrt(len2) : 0.0f;
      for (int k = 0; k < 3; ++k) b.nrm.push_back(n[k] * s);
    }
    if (has_uv)
      for (int k = 0; k < 2; ++k) b.uv.push_back((b.uv[2 * i + k] + b.uv[2 * j + k]) * 0.5f);
    it->second = static_cast<std::int32_t>(b.pos.size() / 3 - 1);
    return it->second;
  };
  std::vector<std::int32_t> old;
  old.swap(b.tri);
  b.tri.reserve(old.size() * 4);
  for (std::size_t t = 0; t < old.size(); t += 3) {
    const std::int32_t a = old[t], c1 = old[t + 1], c2 = old[t + 2];
    const std::int32_t ab = midpoint(a, c1), bc = midpoint(c1, c2), ca = midpoint(c2, a);
    b.triangle(a, ab, ca);
    b.triangle(ab, c1, bc);
    b.triangle(ca, bc, c2);
    b.triangle(ab, bc, ca);
  }
}

}  // namespace

Mesh make_cube(float size) {
  require(positive_finite(size), "make_cube: size must be positive and finite, got " +
                                     std::to_string(size));
  const float h = size * 0.5f;
  // Per face: outward normal n and in-plane axes u, v with u × v = n.
  static const float faces[6][3][3] = {
      {{1, 0, 0}, {0, 0, -1}, {0, 1, 0}},  {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
      {{0, 1, 0}, {1, 0, 0}, {0, 0, -1}},  {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
      {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}},   {{0, 0, -1}, {-1, 0, 0}, {0, 1, 0}}};
  static const float corner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  Builder b;
  for (const auto& f : faces) {
    std::int32_t first = 0;
    for (int c = 0; c < 4; ++c) {
      const float su = corner[c][0] * 2 - 1, sv = corner[c][1] * 2 - 1;
      float p[3];
      // Every term is 0 or ±h, so shared corners are bit-identical.
      for (int k = 0; k < 3; ++k) p[k] = f[0][k] * h + su * f[1][k] * h + sv * f[2][k] * h;
      const std::int32_t v = b.vertex(p, f[0], corner[c][0], corner[c][1]);
      if (c == 0) first = v;
    }
    b.triangle(first, first + 1, first + 2);
    b.triangle(first, first + 2, first + 3);
  }
  return b.mesh();
}

Mesh make_uv_sphere(int rings, int segments, float radius) {
  require(rings >= 2 && segments >= 3, "make_uv_sphere: needs rings >= 2 and segments >= 3, got " +
                                           std::to_string(rings) + " and " +
                                           std::to_string(segments));
  require(positive_finite(radius), "make_uv_sphere: radius must be positive and finite");
  require_addressable("make_uv_sphere", (rings + 1.0) * (segments + 1.0));
  Builder b;
  // Vertex (i, j): latitude i from the south pole, longitude j (seam copy at j = segments).
  for (int i = 0; i <= rings; ++i) {
    const double theta = kPi * i / rings;
    const double y = (i == 0) ? -1.0 : (i == rings) ? 1.0 : -std::cos(theta);
    const double ring = (i == 0 || i == rings) ? 0.0 : std::sin(theta);
    for (int j = 0; j <= segments; ++j) {
      const double phi = 2 * kPi * (j % segments) / segments;
      const float n[3] = {static_cast<float>(ring * std::sin(phi)), static_cast<float>(y),
                          static_cast<float>(ring * std::cos(phi))};
      const float p[3] = {n[0] * radius, n[1] * radius, n[2] * radius};
      b.vertex(p, n, static_cast<float>(j) / segments, static_cast<float>(i) / rings);
    }
  }
  // Cells: two triangles each, one at the poles where an edge collapses.
  auto id = [&](int i, int j) { return i * (segments + 1) + j; };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      if (i > 0) b.triangle(id(i, j), id(i, j + 1), id(i + 1, j + 1));
      if (i < rings - 1) b.triangle(id(i, j), id(i + 1, j + 1), id(i + 1, j));
    }
  return b.mesh();
}

Mesh make_icosphere(int subdivisions, float radius) {
  require(subdivisions >= 0 && subdivisions <= 10,
          "make_icosphere: subdivisions must be in [0, 10], got " + std::to_string(subdivisions));
  require(positive_finite(radius), "make_icosphere: radius must be positive and finite");
  // Icosahedron: vertices (0, ±1, ±g), (±1, ±g, 0), (±g, 0, ±1), g = golden ratio.
  const float g = static_cast<float>((1 + std::sqrt(5.0)) / 2);
  const float v[12][3] = {{-1, g, 0}, {1, g, 0},  {-1, -g, 0}, {1, -g, 0},
                          {0, -1, g}, {0, 1, g},  {0, -1, -g}, {0, 1, -g},
                          {g, 0, -1}, {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  static const int f[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                               {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                               {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                               {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  Builder b;
  for (const auto& p : v) b.pos.insert(b.pos.end(), p, p + 3);
  for (const auto& t : f) b.triangle(t[0], t[1], t[2]);
  // Project onto the unit sphere, then subdivide and project again, level by level.
  auto project = [&b] {
    for (std::size_t i = 0; i < b.pos.size(); i += 3) {
      const float len = std::sqrt(b.pos[i] * b.pos[i] + b.pos[i + 1] * b.pos[i + 1] +
                                  b.pos[i + 2] * b.pos[i + 2]);
      for (int k = 0; k < 3; ++k) b.pos[i + k] /= len;
    }
  };
  project();
  for (int s = 0; s < subdivisions; ++s) {
    subdivide_builder(b);
    project();
  }
  // Normals, equirectangular uvs, then scale to the radius.
  const std::size_t n = b.pos.size() / 3;
  b.nrm = b.pos;
  b.uv.resize(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = &b.pos[3 * i];
    double u = std::atan2(static_cast<double>(p[0]), static_cast<double>(p[2])) / (2 * kPi);
    if (u < 0) u += 1;
    b.uv[2 * i] = static_cast<float>(std::min(u, 1.0));
    const double v = 0.5 + std::asin(std::clamp(static_cast<double>(p[1]), -1.0, 1.0)) / kPi;
    b.uv[2 * i + 1] = static_cast<float>(std::clamp(v, 0.0, 1.0));
  }
  for (float& x : b.pos) x *= radius;
  return b.mesh();
}

Mesh make_torus(int major_segments, int minor_segments, float R, float r) {
  require(major_segments >= 3 && minor_segments >= 3,
          "make_torus: needs major_segments >= 3 and minor_segments >= 3, got " +
              std::to_string(major_segments) + " and " + std::to_string(minor_segments));
  require(positive_finite(R) && positive_finite(r) && r < R,
          "make_torus: needs 0 < r < R (finite), got R = " + std::to_string(R) +
              ", r = " + std::to_string(r));
  require_addressable("make_torus", (major_segments + 1.0) * (minor_segments + 1.0));
  Builder b;
  // Vertex (i, j): angle i around y, angle j around the tube (seam copies at the ends).
  for (int i = 0; i <= major_segments; ++i) {
    const double phi = 2 * kPi * (i % major_segments) / major_segments;
    const double dx = std::sin(phi), dz = std::cos(phi);
    for (int j = 0; j <= minor_segments; ++j) {
      const double theta = 2 * kPi * (j % minor_segments) / minor_segments;
      const double c = std::cos(theta), s = std::sin(theta);
      const float n[3] = {static_cast<float>(c * dx), static_cast<float>(s),
                          static_cast<float>(c * dz)};
      const float p[3] = {static_cast<float>((R + r * c) * dx), static_cast<float>(r * s),
                          static_cast<float>((R + r * c) * dz)};
      b.vertex(p, n, static_cast<float>(i) / major_segments,
               static_cast<float>(j) / minor_segments);
    }
  }
  auto id = [&](int i, int j) { return i * (minor_segments + 1) + j; };
  for (int i = 0; i < major_segments; ++i)
    for (int j = 0; j < minor_segments; ++j) {
      b.triangle(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      b.triangle(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  return b.mesh();
}

Mesh make_plane(int nx, int ny, float size) {
  require(nx >= 1 && ny >= 1, "make_plane: needs nx >= 1 and ny >= 1, got " +
                                  std::to_string(nx) + " and " + std::to_string(ny));
  require(positive_finite(size), "make_plane: size must be positive and finite");
  require_addressable("make_plane", (nx + 1.0) * (ny + 1.0));
  Builder b;
  const float n[3] = {0, 0, 1};
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const float u = static_cast<float>(i) / nx, v = static_cast<float>(j) / ny;
      const float p[3] = {(u - 0.5f) * size, (v - 0.5f) * size, 0.0f};
      b.vertex(p, n, u, v);
    }
  auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      b.triangle(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      b.triangle(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  return b.mesh();
}

Mesh subdivide(const Mesh& mesh) {
  mesh.validate("subdivide");
  require_addressable("subdivide", mesh.num_vertices() + 1.5 * mesh.num_triangles() * 1.0 + 1);
  Builder b;
  const float* p = mesh.positions.data<float>();
  b.pos.assign(p, p + mesh.positions.numel());
  if (mesh.has_normals()) b.nrm.assign(mesh.normals.data<float>(), mesh.normals.data<float>() + mesh.normals.numel());
  if (mesh.has_uvs()) b.uv.assign(mesh.uvs.data<float>(), mesh.uvs.data<float>() + mesh.uvs.numel());
  const std::int32_t* t = mesh.triangles.data<std::int32_t>();
  b.tri.assign(t, t + mesh.triangles.numel());
  subdivide_builder(b);
  Mesh out = b.mesh();
  out.texture_path = mesh.texture_path;
  return out;
}

}  // namespace gr::raster
