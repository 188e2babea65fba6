// Tests of raster/procedural.h: triangle and vertex counts, closed meshes that
// are watertight 2-manifolds (after welding seam copies by position), outward
// counter-clockwise winding, consistent normals and uvs, and subdivision.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <map>

#include "autodiff/base/error.h"
#include "raster/procedural.h"

using namespace gr;
using namespace gr::raster;

namespace {

using V3 = std::array<double, 3>;

V3 pos(const Mesh& m, std::int64_t v) {
  const float* p = m.positions.data<float>() + 3 * v;
  return {p[0], p[1], p[2]};
}
V3 sub(V3 a, V3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// Vertex ids after welding vertices with bit-identical positions.
std::vector<int> welded_ids(const Mesh& m) {
  std::map<std::array<float, 3>, int> ids;
  std::vector<int> out(m.num_vertices());
  const float* p = m.positions.data<float>();
  for (std::int64_t v = 0; v < m.num_vertices(); ++v)
    out[v] = ids.emplace(std::array<float, 3>{p[3 * v], p[3 * v + 1], p[3 * v + 2]},
                         static_cast<int>(ids.size()))
                 .first->second;
  return out;
}

// Closed and consistently oriented: every directed edge (welded) appears exactly
// once and its reverse exactly once, so each edge has two triangles that
// traverse it in opposite directions. Returns false at the first violation.
bool is_closed_oriented_manifold(const Mesh& m) {
  const std::vector<int> id = welded_ids(m);
  std::map<std::pair<int, int>, int> directed;
  const std::int32_t* t = m.triangles.data<std::int32_t>();
  for (std::int64_t f = 0; f < m.num_triangles(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = id[t[3 * f + k]], b = id[t[3 * f + (k + 1) % 3]];
      if (a == b) return false;  // degenerate edge
      if (++directed[{a, b}] > 1) return false;
    }
  for (const auto& [edge, count] : directed)
    if (directed.count({edge.second, edge.first}) == 0) return false;
  return true;
}

// Enclosed volume by the divergence theorem (positive for outward winding).
double signed_volume(const Mesh& m) {
  const std::int32_t* t = m.triangles.data<std::int32_t>();
  double vol = 0;
  for (std::int64_t f = 0; f < m.num_triangles(); ++f)
    vol += dot(pos(m, t[3 * f]), cross(pos(m, t[3 * f + 1]), pos(m, t[3 * f + 2]))) / 6;
  return vol;
}

// Every triangle's geometric normal agrees with its vertex normals.
bool normals_agree_with_winding(const Mesh& m) {
  const std::int32_t* t = m.triangles.data<std::int32_t>();
  const float* n = m.normals.data<float>();
  for (std::int64_t f = 0; f < m.num_triangles(); ++f) {
    const V3 a = pos(m, t[3 * f]);
    const V3 g = cross(sub(pos(m, t[3 * f + 1]), a), sub(pos(m, t[3 * f + 2]), a));
    for (int k = 0; k < 3; ++k) {
      const float* vn = n + 3 * t[3 * f + k];
      if (dot(g, {vn[0], vn[1], vn[2]}) <= 0) return false;
    }
  }
  return true;
}

bool unit_normals_and_uvs_in_range(const Mesh& m) {
  const float* n = m.normals.data<float>();
  const float* uv = m.uvs.data<float>();
  for (std::int64_t v = 0; v < m.num_vertices(); ++v) {
    const double len = std::sqrt(dot({n[3 * v], n[3 * v + 1], n[3 * v + 2]},
                                     {n[3 * v], n[3 * v + 1], n[3 * v + 2]}));
    if (std::fabs(len - 1) > 1e-5) return false;
    if (uv[2 * v] < 0 || uv[2 * v] > 1 || uv[2 * v + 1] < 0 || uv[2 * v + 1] > 1) return false;
  }
  return true;
}

void check_closed_mesh(const Mesh& m, double expected_volume, double rel_tol) {
  REQUIRE_NOTHROW(m.validate("test"));
  REQUIRE(m.has_normals());
  REQUIRE(m.has_uvs());
  CHECK(is_closed_oriented_manifold(m));
  CHECK(signed_volume(m) > 0);
  CHECK(signed_volume(m) == Approx(expected_volume).epsilon(rel_tol));
  CHECK(normals_agree_with_winding(m));
  CHECK(unit_normals_and_uvs_in_range(m));
}

constexpr double kPi = 3.14159265358979323846;

}  // namespace

TEST_CASE("make_cube: 12 outward triangles on 24 vertices enclosing size cubed", "[raster][procedural]") {
  Mesh m = make_cube(3.0f);
  CHECK(m.num_vertices() == 24);
  CHECK(m.num_triangles() == 12);
  check_closed_mesh(m, 27.0, 1e-12);
  for (double x : m.positions.to_vector()) CHECK(std::fabs(x) == 1.5);
}

TEST_CASE("make_uv_sphere: 2·segments·(rings-1) triangles, closed, outward", "[raster][procedural]") {
  for (auto [rings, segments] : {std::pair{2, 3}, std::pair{3, 4}, std::pair{16, 32}, std::pair{50, 99}}) {
    INFO(rings << " rings, " << segments << " segments");
    Mesh m = make_uv_sphere(rings, segments, 2.0f);
    CHECK(m.num_triangles() == 2 * segments * (rings - 1));
    CHECK(m.num_vertices() == (rings + 1) * (segments + 1));
    REQUIRE_NOTHROW(m.validate("test"));
    CHECK(is_closed_oriented_manifold(m));
    CHECK(signed_volume(m) > 0);
    CHECK(normals_agree_with_winding(m));
    CHECK(unit_normals_and_uvs_in_range(m));
  }
  // A fine sphere approaches the true volume.
  check_closed_mesh(make_uv_sphere(64, 128, 2.0f), 4.0 / 3 * kPi * 8, 2e-3);
}

TEST_CASE("make_icosphere: 20·4^s triangles on 10·4^s+2 shared vertices, on the sphere", "[raster][procedural]") {
  for (int s = 0; s <= 4; ++s) {
    INFO("subdivisions " << s);
    Mesh m = make_icosphere(s, 0.5f);
    const std::int64_t f = 20 * (std::int64_t{1} << (2 * s));
    CHECK(m.num_triangles() == f);
    CHECK(m.num_vertices() == f / 2 + 2);  // Euler: V - E + F = 2 with E = 3F/2
    check_closed_mesh(m, 4.0 / 3 * kPi / 8, s < 3 ? 0.5 : 0.02);
    // No welding needed: the mesh itself is closed.
    CHECK(welded_ids(m).size() == static_cast<std::size_t>(m.num_vertices()));
    for (std::int64_t v = 0; v < m.num_vertices(); ++v)
      CHECK(std::sqrt(dot(pos(m, v), pos(m, v))) == Approx(0.5).epsilon(1e-6));
  }
  CHECK(make_icosphere(5).num_triangles() == 20480);
  CHECK(make_icosphere(6).num_triangles() == 81920);
}

TEST_CASE("make_icosphere: 7 subdivisions give 327680 closed triangles quickly", "[raster][procedural][.slow]") {
  Mesh m = make_icosphere(7);
  CHECK(m.num_triangles() == 327680);
  CHECK(is_closed_oriented_manifold(m));
}

TEST_CASE("make_torus: 2·major·minor triangles, closed, volume 2π²Rr²", "[raster][procedural]") {
  Mesh m = make_torus(48, 24, 2.0f, 0.5f);
  CHECK(m.num_triangles() == 2 * 48 * 24);
  CHECK(m.num_vertices() == 49 * 25);
  check_closed_mesh(m, 2 * kPi * kPi * 2.0 * 0.25, 0.02);
  Mesh small = make_torus(3, 3, 1.0f, 0.5f);
  CHECK(small.num_triangles() == 18);
  CHECK(is_closed_oriented_manifold(small));
  CHECK(signed_volume(small) > 0);
}

TEST_CASE("make_plane: 2·nx·ny triangles facing +z with uvs over the unit square", "[raster][procedural]") {
  Mesh m = make_plane(4, 3, 2.0f);
  CHECK(m.num_triangles() == 24);
  CHECK(m.num_vertices() == 20);
  REQUIRE_NOTHROW(m.validate("test"));
  CHECK(normals_agree_with_winding(m));
  CHECK(unit_normals_and_uvs_in_range(m));
  const std::int32_t* t = m.triangles.data<std::int32_t>();
  double area = 0;
  for (std::int64_t f = 0; f < m.num_triangles(); ++f) {
    const V3 a = pos(m, t[3 * f]);
    area += cross(sub(pos(m, t[3 * f + 1]), a), sub(pos(m, t[3 * f + 2]), a))[2] / 2;
  }
  CHECK(area == Approx(4.0));
  // Corner vertex (-1, -1) has uv (0, 0); (1, 1) has uv (1, 1).
  CHECK(m.positions.at({0, 0}) == -1.0f);
  CHECK(m.uvs.at({0, 0}) == 0.0f);
  CHECK(m.positions.at({19, 1}) == 1.0f);
  CHECK(m.uvs.at({19, 1}) == 1.0f);
}

TEST_CASE("subdivide: four triangles per triangle with shared midpoints, shape unchanged", "[raster][procedural]") {
  Mesh cube = make_cube();
  Mesh once = subdivide(cube);
  CHECK(once.num_triangles() == 48);
  check_closed_mesh(once, 8.0, 1e-12);
  Mesh sphere = make_icosphere(2);
  Mesh fine = subdivide(sphere);
  CHECK(fine.num_triangles() == 4 * sphere.num_triangles());
  CHECK(fine.num_vertices() == sphere.num_vertices() + sphere.num_triangles() * 3 / 2);
  CHECK(signed_volume(fine) == Approx(signed_volume(sphere)).epsilon(1e-6));
  CHECK(is_closed_oriented_manifold(fine));
  // Works on seamed meshes and without attributes too.
  Mesh torus = subdivide(make_torus(8, 5, 1.0f, 0.4f));
  CHECK(is_closed_oriented_manifold(torus));
  Mesh bare = make_icosphere(0);
  bare.normals = Tensor();
  bare.uvs = Tensor();
  Mesh bare2 = subdivide(bare);
  CHECK_FALSE(bare2.has_normals());
  CHECK(bare2.num_triangles() == 80);
}

TEST_CASE("procedural generators reject sizes and counts that make no mesh", "[raster][procedural][errors]") {
  CHECK_THROWS_AS(make_cube(0.0f), ValueError);
  CHECK_THROWS_AS(make_cube(std::nanf("")), ValueError);
  CHECK_THROWS_AS(make_uv_sphere(1, 8), ValueError);
  CHECK_THROWS_AS(make_uv_sphere(8, 2), ValueError);
  CHECK_THROWS_AS(make_icosphere(-1), ValueError);
  CHECK_THROWS_AS(make_icosphere(11), ValueError);
  CHECK_THROWS_AS(make_torus(8, 8, 1.0f, 1.0f), ValueError);
  CHECK_THROWS_AS(make_torus(2, 8, 1.0f, 0.5f), ValueError);
  CHECK_THROWS_AS(make_plane(0, 4), ValueError);
  CHECK_THROWS_AS(make_plane(4, 4, -1.0f), ValueError);
}
