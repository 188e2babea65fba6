// Tests of the cube-map kernels: every face's orientation by hand, the
// projection's derivatives, the edge fold (neighbours one texel apart across
// every edge, a bijection), values of a texture whose texels encode their
// face, row and column, seamless bilinear and mipmapped lookups across edges
// and corners, the LOD rule by hand and against the footprint's definition,
// constant textures at every level, the texel gradient's mass, and the texel
// gradients' bits against a plain per-texel sum for any thread count.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/cube_map.h"
#include "raster/cube_texture.h"
#include "raster/kernel_checks.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::testing;

namespace {

// The direction (of length ~q) that hits `face` at (s, t).
std::array<double, 3> direction(int face, double s, double t, double q = 1.0) {
  const CubeFace& f = kCubeFaces[face];
  std::array<double, 3> d{};
  d[f.major] = f.major_sign * q;
  d[f.s_axis] = f.s_sign * (2 * s - 1) * q;
  d[f.t_axis] = f.t_sign * (2 * t - 1) * q;
  return d;
}

// The centre of texel (col, row) of a face of size S, on the cube [-1, 1]^3.
std::array<double, 3> texel_centre(int face, int col, int row, int S) {
  return direction(face, (col + 0.5) / S, (row + 0.5) / S);
}

// Lookups of a 6 x S x S x C texture (mipmapped: with its per-face pyramid).
struct Cube {
  int S, C;
  std::vector<double> faces, pyramid;
  MipLayout layout;
  Cube(int size, int channels, std::vector<double> texels, int max_level = -1)
      : S(size), C(channels), faces(std::move(texels)), layout(mip_layout(size, size, max_level)) {
    pyramid.resize(6 * (layout.total_texels - S * S) * C);
    cube_mip_build(faces.data(), C, layout, pyramid.data());
  }
  CubeTextureParams<double> params(const std::vector<double>& dir, CubeFilter filter) const {
    CubeTextureParams<double> p;
    p.faces = faces.data();
    p.pyramid = pyramid.data();
    p.layout = is_mipmapped(filter) ? layout : mip_layout(S, S, 0);
    p.channels = C;
    p.dir = dir.data();
    p.num_samples = static_cast<std::int64_t>(dir.size() / 3);
    p.filter = filter;
    return p;
  }
  // Samples at `dir` (num x 3); mipmapped filters take their LOD from `bias`.
  std::vector<double> lookup(const std::vector<double>& dir, CubeFilter filter, const std::vector<double>& bias = {}) const {
    CubeTextureParams<double> p = params(dir, filter);
    p.mip_level_bias = bias.empty() ? nullptr : bias.data();
    std::vector<double> out(dir.size() / 3 * C);
    cube_texture_forward(p, out.data());
    return out;
  }
  std::vector<double> at(const std::array<double, 3>& d, CubeFilter filter = CubeFilter::Bilinear,
                         double lod = 0) const {
    return lookup({d[0], d[1], d[2]}, filter, is_mipmapped(filter) ? std::vector<double>{lod} : std::vector<double>{});
  }
};

// Texel (face, row, col) holds (face, row, col): a lookup says where it read.
Cube coded_cube(int S) {
  std::vector<double> t;
  for (int f = 0; f < 6; ++f)
    for (int r = 0; r < S; ++r)
      for (int c = 0; c < S; ++c) t.insert(t.end(), {double(f), double(r), double(c)});
  return Cube(S, 3, t);
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

}  // namespace

TEST_CASE("cube map: each face's direction, s and t follow the GL table, worked by hand", "[raster][cube]") {
  // face, direction, s, t: sc, tc from the table, s = (sc/|ma| + 1)/2, t = (tc/|ma| + 1)/2.
  struct Case {
    int face;
    double x, y, z, s, t;
  };
  const Case cases[] = {
      {0, 2, 0.5, -1, 0.75, 0.375},   // +X: sc = -z = 1,    tc = -y = -0.5, |ma| = 2
      {1, -2, 0.5, -1, 0.25, 0.375},  // -X: sc = +z = -1,   tc = -y = -0.5
      {2, 0.5, 2, -1, 0.625, 0.25},   // +Y: sc = +x = 0.5,  tc = +z = -1
      {3, 0.5, -2, -1, 0.625, 0.75},  // -Y: sc = +x = 0.5,  tc = -z = 1
      {4, 0.5, -1, 2, 0.625, 0.75},   // +Z: sc = +x = 0.5,  tc = -y = 1
      {5, 0.5, -1, -2, 0.375, 0.75},  // -Z: sc = -x = -0.5, tc = -y = 1
  };
  for (const Case& c : cases)
    for (double scale : {1.0, 0.01, 37.0}) {
      INFO("face " << c.face << " scale " << scale);
      const CubeProjection p = cube_project(scale * c.x, scale * c.y, scale * c.z);
      CHECK(p.face == c.face);
      CHECK(p.s == Approx(c.s).epsilon(1e-15));
      CHECK(p.t == Approx(c.t).epsilon(1e-15));
    }
  // Ties (directions on an edge or a corner): z only if strictly largest, then y over x.
  CHECK(cube_project(1, 1, 1).face == 0);
  CHECK(cube_project(-1, 1, 1).face == 1);
  CHECK(cube_project(0, 1, 1).face == 2);
  CHECK(cube_project(0, -1, -1).face == 3);
  CHECK(cube_project(0.5, 0.5, 1).face == 4);
  CHECK(cube_project(0, 0, 0).face == -1);  // the zero vector has no face
  // Texel row = t S: on a 4 x 4 +X face, (1, 0.3, -0.6) has s = 0.8, t = 0.35: column 3, row 1.
  const Cube cube = coded_cube(4);
  CHECK(cube.at({1, 0.3, -0.6}, CubeFilter::Nearest) == std::vector<double>{0, 1, 3});
}

TEST_CASE("cube map: the projection's first and second derivatives match finite differences", "[raster][cube]") {
  const std::vector<double> dirs = random_vector(3 * 40, -2, 2, 7);
  for (std::size_t i = 0; i < dirs.size(); i += 3) {
    const std::vector<double> d(dirs.begin() + i, dirs.begin() + i + 3);
    const CubeProjection p = cube_project(d[0], d[1], d[2]);
    // Stay on one face within the finite-difference steps.
    const std::array<double, 3> a = {std::abs(d[0]), std::abs(d[1]), std::abs(d[2])};
    std::array<double, 3> sorted = a;
    std::sort(sorted.begin(), sorted.end());
    if (sorted[2] - sorted[1] < 1e-3) continue;
    auto s_of = [](const std::vector<double>& v) { return cube_project(v[0], v[1], v[2]).s; };
    auto t_of = [](const std::vector<double>& v) { return cube_project(v[0], v[1], v[2]).t; };
    CHECK(fd_error(s_of, d, {p.ds[0], p.ds[1], p.ds[2]}) < 1e-8);
    CHECK(fd_error(t_of, d, {p.dt[0], p.dt[1], p.dt[2]}) < 1e-8);
    // (d^2 s / d dir^2) v = d(ds/d(dir) . v)/d(dir).
    const std::vector<double> v = random_vector(3, -1, 1, 100 + unsigned(i));
    double hs[3], ht[3];
    cube_project_hessian_times(p, v.data(), hs, ht);
    auto ds_v = [&](const std::vector<double>& x) {
      const CubeProjection q = cube_project(x[0], x[1], x[2]);
      return q.ds[0] * v[0] + q.ds[1] * v[1] + q.ds[2] * v[2];
    };
    auto dt_v = [&](const std::vector<double>& x) {
      const CubeProjection q = cube_project(x[0], x[1], x[2]);
      return q.dt[0] * v[0] + q.dt[1] * v[1] + q.dt[2] * v[2];
    };
    CHECK(fd_error(ds_v, d, {hs[0], hs[1], hs[2]}) < 1e-7);
    CHECK(fd_error(dt_v, d, {ht[0], ht[1], ht[2]}) < 1e-7);
  }
}

TEST_CASE("cube map: a texel off an edge is the neighbour's texel one texel away, and every edge texel is reached once",
          "[raster][cube]") {
  for (int S : {1, 2, 3, 5, 8}) {
    INFO("S = " << S);
    // Neighbour's texel (face, col, row) -> how many off-edge taps reach it from each face.
    std::map<std::array<int, 4>, int> reached;
    for (int face = 0; face < 6; ++face)
      for (int k = 0; k < S; ++k) {
        // The 4 edges: (col, row) one step off, and the in-face texel next to it.
        const int off[4][4] = {{-1, k, 0, k}, {S, k, S - 1, k}, {k, -1, k, 0}, {k, S, k, S - 1}};
        for (const auto& o : off) {
          const CubeTexel n = cube_texel(face, o[0], o[1], S);
          REQUIRE(n.face >= 0);
          CHECK(n.face != face);
          CHECK(n.face / 2 != face / 2);  // never the opposite face
          REQUIRE((n.col >= 0 && n.col < S && n.row >= 0 && n.row < S));
          // Across the edge both centres are half a texel from it, on perpendicular
          // faces: sqrt(2) / S apart (on the cube [-1, 1]^3, texels 2 / S wide).
          const auto a = texel_centre(face, o[2], o[3], S), b = texel_centre(n.face, n.col, n.row, S);
          const double dist = std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
          CHECK(dist == Approx(std::sqrt(2.0) / S).epsilon(1e-12));
          ++reached[{face, n.face, n.col, n.row}];
        }
      }
    // From each face, the 4S off-edge taps land on 4S distinct texels of 4 neighbours (S = 1: 4 faces, once each).
    for (int face = 0; face < 6; ++face) {
      int distinct = 0;
      for (const auto& [key, count] : reached)
        if (key[0] == face) {
          ++distinct;
          CHECK(count == 1);
        }
      CHECK(distinct == 4 * S);
    }
    // Off two edges at once (a cube corner): no texel.
    CHECK(cube_texel(0, -1, -1, S).face == -1);
    CHECK(cube_texel(5, S, -1, S).face == -1);
    CHECK(cube_texel(3, S, S, S).face == -1);
    // In range: the texel itself.
    CHECK(cube_texel(2, S - 1, 0, S).face == 2);
  }
}

TEST_CASE("cube map: nearest reads the texel a direction hits, bilinear blends across edges and corners as worked by hand",
          "[raster][cube]") {
  const int S = 4;
  const Cube cube = coded_cube(S);
  // Every texel centre reads itself, by nearest and by bilinear (weight 1 on it).
  for (int f = 0; f < 6; ++f)
    for (int r = 0; r < S; ++r)
      for (int c = 0; c < S; ++c) {
        const std::vector<double> code{double(f), double(r), double(c)};
        const auto d = texel_centre(f, c, r, S);
        CHECK(cube.at(d, CubeFilter::Nearest) == code);
        CHECK(max_abs_diff(cube.at(d), code) < 1e-15);
      }
  // On the +X / +Z edge (x = z = 1), at row r's centre: s = 0 on +X (x = -0.5),
  // half of +X (r, col 0) and half of +Z (r, col S - 1).
  for (int r = 0; r < S; ++r) {
    const double y = 1 - 2 * (r + 0.5) / S;
    CHECK(max_abs_diff(cube.at({1, y, 1}), {2, double(r), 1.5}) < 1e-15);
  }
  // At the corner (1, 1, 1): only 3 texels meet (+X (0, 0), +Y (S-1, S-1),
  // +Z (0, S-1)); the 4th tap reads their mean, so the lookup is their mean,
  // whichever face the direction is on.
  const std::vector<double> mean{(0 + 2 + 4) / 3.0, (0 + 3 + 0) / 3.0, (0 + 3 + 3) / 3.0};
  CHECK(max_abs_diff(cube.at({1, 1, 1}), mean) < 1e-15);
  CHECK(max_abs_diff(cube.at({1 - 1e-12, 1, 1}), mean) < 1e-9);  // on +Y
  CHECK(max_abs_diff(cube.at({1 - 1e-12, 1 - 1e-12, 1}), mean) < 1e-9);  // on +Z
  // The zero direction reads 0.
  CHECK(cube.at({0, 0, 0}) == std::vector<double>{0, 0, 0});
}

TEST_CASE("cube map: bilinear and mipmapped lookups are continuous across all 12 edges and 8 corners", "[raster][cube]") {
  const int S = 5;
  const Cube cube(S, 2, random_vector(6 * S * S * 2, -1, 1, 3));
  const double delta = 1e-9;
  for (double lod : {0.0, 1.4, 2.0}) {
    const CubeFilter filter = lod == 0 ? CubeFilter::Bilinear : CubeFilter::Trilinear;
    INFO("lod " << lod);
    double worst = 0;
    // Edges: two axes at +-1, the third anywhere; step into either face.
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j)
        for (int si : {-1, 1})
          for (int sj : {-1, 1})
            for (double u : {-0.93, -0.41, 0.0, 0.27, 0.88}) {
              std::array<double, 3> p{};
              p[i] = si, p[j] = sj, p[3 - i - j] = u;
              std::array<double, 3> a = p, b = p;
              a[j] -= sj * delta;  // on face i
              b[i] -= si * delta;  // on face j
              REQUIRE(cube_project(a[0], a[1], a[2]).face == 2 * i + (si < 0));
              REQUIRE(cube_project(b[0], b[1], b[2]).face == 2 * j + (sj < 0));
              worst = std::max(worst, max_abs_diff(cube.at(a, filter, lod), cube.at(b, filter, lod)));
              worst = std::max(worst, max_abs_diff(cube.at(a, filter, lod), cube.at(p, filter, lod)));
            }
    // Corners: approach from each of the 3 faces.
    for (int sx : {-1, 1})
      for (int sy : {-1, 1})
        for (int sz : {-1, 1}) {
          const std::array<double, 3> p{double(sx), double(sy), double(sz)};
          const std::vector<double> at_corner = cube.at(p, filter, lod);
          for (int major = 0; major < 3; ++major) {
            std::array<double, 3> a = p;
            for (int k = 0; k < 3; ++k)
              if (k != major) a[k] *= 1 - delta;
            REQUIRE(cube_project(a[0], a[1], a[2]).face == 2 * major + (p[major] < 0));
            worst = std::max(worst, max_abs_diff(cube.at(a, filter, lod), at_corner));
          }
        }
    CHECK(worst < 1e-7);
  }
  SECTION("a sweep across an edge has no jump larger than its slope allows") {
    // (1, 0.3, z) for z from 0.8 to 1.2 crosses from +X onto +Z at z = 1.
    const int steps = 4000;
    double largest = 0;
    std::vector<double> prev = cube.at({1, 0.3, 0.8});
    for (int k = 1; k <= steps; ++k) {
      const std::vector<double> now = cube.at({1, 0.3, 0.8 + 0.4 * k / steps});
      largest = std::max(largest, max_abs_diff(now, prev));
      prev = now;
    }
    // |d out/dz| <= max|texel difference| (2) * S * (|ds/dz| + |dt/dz|) (<= 0.65)
    // < 2 S per unit z; a seam that did not match would jump by O(1).
    CHECK(largest < 2.0 * S * 0.4 / steps);
  }
}

TEST_CASE("cube map: the LOD is log2 of the footprint's major axis in face texels", "[raster][cube]") {
  const int S = 16, L = 5;
  // +Z centre: ds/dx = 1/2, dt/dy = -1/2; dX = (0.25, 0, 0), dY = (0, 0.1, 0)
  // -> sX = 16 * 0.125 = 2, tY = -0.8: major axis 2, lod 1.
  const double centre[3] = {0, 0, 1};
  const double da[6] = {0.25, 0, 0, 0.1, 0, 0};  // (dx/dX, dx/dY, dy/dX, dy/dY, dz/dX, dz/dY)
  CHECK(cube_texture_lod(centre, da, S, L) == Approx(1.0).epsilon(1e-14));
  // Twice as long a direction: half the angle per unit, one level finer.
  const double far[3] = {0, 0, 2};
  CHECK(cube_texture_lod(far, da, S, L) == Approx(0.0).margin(1e-14));
  // Quotient rule along the major axis: at (0.5, 0, 1) ds/dz = -x / (2 z^2) = -1/4,
  // so dz/dX = 0.5 gives sX = 16 * -0.125 = -2: lod 1.
  const double off[3] = {0.5, 0, 1};
  const double along_z[6] = {0, 0, 0, 0, 0.5, 0};
  CHECK(cube_texture_lod(off, along_z, S, L) == Approx(1.0).epsilon(1e-14));
  // Bias adds; the result is clamped to [0, L - 1]; bias alone is the LOD.
  CHECK(cube_texture_lod(centre, da, S, L, 0.75) == Approx(1.75).epsilon(1e-14));
  CHECK(cube_texture_lod(centre, da, S, L, 9.0) == L - 1);
  CHECK(cube_texture_lod(centre, da, S, L, -3.0) == 0.0);
  CHECK(cube_texture_lod(centre, nullptr, S, L, 2.5) == 2.5);
  const double zero_da[6] = {0, 0, 0, 0, 0, 0};
  CHECK(cube_texture_lod(centre, zero_da, S, L) == 0.0);  // no footprint: magnification
  // Skewed footprints: the major axis is the longest image of a unit screen step.
  const std::vector<double> dirs = random_vector(3 * 20, -1, 1, 11), das = random_vector(6 * 20, -0.1, 0.1, 12);
  for (int i = 0; i < 20; ++i) {
    const CubeProjection p = cube_project(dirs[3 * i], dirs[3 * i + 1], dirs[3 * i + 2]);
    const double* d = &das[6 * i];
    double longest = 0;
    for (int k = 0; k < 200000; ++k) {
      const double a = M_PI * k / 200000, c = std::cos(a), s = std::sin(a);
      const double step[3] = {d[0] * c + d[1] * s, d[2] * c + d[3] * s, d[4] * c + d[5] * s};
      const double ls = S * (p.ds[0] * step[0] + p.ds[1] * step[1] + p.ds[2] * step[2]);
      const double lt = S * (p.dt[0] * step[0] + p.dt[1] * step[1] + p.dt[2] * step[2]);
      longest = std::max(longest, ls * ls + lt * lt);
    }
    CHECK(cube_texture_lod(&dirs[3 * i], d, S, 40, 10.0) == Approx(0.5 * std::log2(longest) + 10.0).epsilon(1e-9));
  }
}

TEST_CASE("cube map: a constant cube stays constant at every level, filter and corner", "[raster][cube]") {
  const int S = 7;  // 7 -> 3 -> 1
  const Cube cube(S, 1, std::vector<double>(6 * S * S, 0.375));
  REQUIRE(cube.layout.count() == 3);
  std::vector<double> dirs = random_vector(3 * 200, -1, 1, 13);
  for (double c : {1.0, -1.0}) dirs.insert(dirs.end(), {c, 1, -1, 1, c, c * 0.999});
  const std::int64_t n = static_cast<std::int64_t>(dirs.size() / 3);
  std::vector<double> bias;
  for (std::int64_t i = 0; i < n; ++i) bias.push_back(-0.5 + 3.0 * i / n);
  for (CubeFilter f : {CubeFilter::Nearest, CubeFilter::Bilinear, CubeFilter::LinearMipmapNearest, CubeFilter::Trilinear})
    for (double x : cube.lookup(dirs, f, is_mipmapped(f) ? bias : std::vector<double>{}))
      CHECK(x == Approx(0.375).epsilon(1e-14));
}

TEST_CASE("cube map: texel gradients carry exactly the incoming gradient, corners and pyramid included", "[raster][cube]") {
  const int S = 6;
  const Cube cube(S, 2, random_vector(6 * S * S * 2, 0, 1, 14));
  std::vector<double> dirs = random_vector(3 * 300, -1, 1, 15);
  for (int k = 0; k < 8; ++k) dirs.insert(dirs.end(), {k & 1 ? 1.0 : -1.0, k & 2 ? 0.98 : -0.98, k & 4 ? 0.97 : -0.97});
  const std::int64_t n = static_cast<std::int64_t>(dirs.size() / 3);
  const std::vector<double> g = random_vector(2 * n, -1, 1, 16), da = random_vector(6 * n, -0.3, 0.3, 17);
  for (CubeFilter f : {CubeFilter::Nearest, CubeFilter::Bilinear, CubeFilter::LinearMipmapNearest, CubeFilter::Trilinear}) {
    CubeTextureParams<double> p = cube.params(dirs, f);
    p.dir_da = da.data();
    std::vector<double> grad(6 * S * S * 2, 0.0);
    CubeTextureGrads<double> grads;
    grads.faces = grad.data();
    cube_texture_backward(p, g.data(), grads);
    for (int c = 0; c < 2; ++c) {
      double got = 0, want = 0;
      for (std::size_t i = c; i < grad.size(); i += 2) got += grad[i];
      for (std::size_t i = c; i < g.size(); i += 2) want += g[i];
      CHECK(got == Approx(want).epsilon(1e-12));
    }
  }
}

namespace {

// Texel gradients summed the plain way, as the adjoint did with one buffer of
// all levels: every tap weight found by probing the forward (in double, texel
// j_k of a batch one in channel k, 0 elsewhere, so out[i][k] = w(i, j_k)); per
// texel of every level, in sample order, dL/d texel += w g in double; each
// face's levels down to level 0 (mip_backward); rounded once into T.
template <class T>
std::vector<T> plain_texel_gradients(const CubeTextureParams<T>& p, const T* g) {
  const std::int64_t C = p.channels, N = p.num_samples, total = p.layout.total_texels;
  const std::int64_t base = std::int64_t(p.layout.levels[0].width) * p.layout.levels[0].width;
  const std::int64_t K = 64;  // texels probed per forward call
  const std::vector<double> dir(p.dir, p.dir + 3 * N);
  const std::vector<double> da = p.dir_da ? std::vector<double>(p.dir_da, p.dir_da + 6 * N) : std::vector<double>{};
  const std::vector<double> bias =
      p.mip_level_bias ? std::vector<double>(p.mip_level_bias, p.mip_level_bias + N) : std::vector<double>{};
  std::vector<double> faces(6 * base * K, 0.0), pyramid(std::max<std::int64_t>(1, 6 * (total - base) * K), 0.0);
  std::vector<double> w(N * K);
  CubeTextureParams<double> q;
  q.faces = faces.data();
  q.pyramid = pyramid.data();
  q.layout = p.layout;
  q.channels = K;
  q.dir = dir.data();
  q.dir_da = p.dir_da ? da.data() : nullptr;
  q.mip_level_bias = p.mip_level_bias ? bias.data() : nullptr;
  q.num_samples = N;
  q.filter = p.filter;
  // Texel r of face f's levels (the probe's one) and its sums at (f total + r) C.
  auto one = [&](std::int64_t j) -> double& {
    const std::int64_t f = j / total, r = j % total;
    return r < base ? faces[(f * base + r) * K + j % K] : pyramid[(f * (total - base) + r - base) * K + j % K];
  };
  std::vector<double> acc(6 * total * C, 0.0);
  for (std::int64_t j0 = 0; j0 < 6 * total; j0 += K) {
    const std::int64_t j1 = std::min(6 * total, j0 + K);
    for (std::int64_t j = j0; j < j1; ++j) one(j) = 1.0;
    cube_texture_forward(q, w.data());
    for (std::int64_t j = j0; j < j1; ++j) {
      one(j) = 0.0;
      double* a = &acc[j * C];
      for (std::int64_t i = 0; i < N; ++i) {
        const double wi = w[i * K + j % K];
        if (wi == 0.0) continue;
        for (std::int64_t c = 0; c < C; ++c) a[c] += wi * g[i * C + c];
      }
    }
  }
  std::vector<T> out(6 * base * C);
  for (std::int64_t f = 0; f < 6; ++f) {
    if (total > base) mip_backward(C, p.layout, &acc[f * total * C]);
    for (std::int64_t k = 0; k < base * C; ++k) out[f * base * C + k] = static_cast<T>(acc[f * total * C + k]);
  }
  return out;
}

// Random directions (with the 8 corners, the zero direction and samples whose
// incoming gradient is 0) on a cube of S x S faces; the adjoint's texel
// gradients at 1, 2 and 8 threads equal the plain sums bit for bit, the
// direction gradients equal each other.
template <class T>
void check_texel_gradient_bits(int S, int max_level, CubeFilter filter, bool footprint, bool with_bias, int n) {
  const int C = 3;
  std::vector<double> d = random_vector(3 * n, -1, 1, 21);
  for (int k = 0; k < 8; ++k) d.insert(d.end(), {k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0});
  d.insert(d.end(), {0.0, 0.0, 0.0});
  const std::int64_t N = static_cast<std::int64_t>(d.size() / 3);
  std::vector<double> gd = random_vector(C * N, -1, 1, 22);
  for (std::int64_t i = 0; i < N; i += 7) std::fill(gd.begin() + i * C, gd.begin() + (i + 1) * C, 0.0);
  const std::vector<double> dad = random_vector(6 * N, -0.4, 0.4, 23), biasd = random_vector(N, -0.5, 3.5, 24);
  const std::vector<double> texd = random_vector(6 * S * S * C, 0, 1, 25);
  const std::vector<T> dir(d.begin(), d.end()), g(gd.begin(), gd.end()), da(dad.begin(), dad.end());
  const std::vector<T> bias(biasd.begin(), biasd.end()), tex(texd.begin(), texd.end());
  CubeTextureParams<T> p;
  p.layout = is_mipmapped(filter) ? mip_layout(S, S, max_level) : mip_layout(S, S, 0);
  std::vector<T> pyramid(6 * (p.layout.total_texels - S * S) * C + 1);
  cube_mip_build(tex.data(), C, p.layout, pyramid.data());
  p.faces = tex.data();
  p.pyramid = pyramid.data();
  p.channels = C;
  p.dir = dir.data();
  p.dir_da = footprint ? da.data() : nullptr;
  p.mip_level_bias = with_bias ? bias.data() : nullptr;
  p.num_samples = N;
  p.filter = filter;
  const std::vector<T> want = plain_texel_gradients(p, g.data());
  std::vector<T> dir_grad_1;
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    std::vector<T> grad_faces(tex.size(), T(0)), grad_dir(dir.size(), T(0));
    CubeTextureGrads<T> grads;
    grads.faces = grad_faces.data();
    grads.dir = grad_dir.data();
    cube_texture_backward(p, g.data(), grads);
    CHECK(grad_faces == want);
    if (threads == 1) dir_grad_1 = grad_dir;
    CHECK(grad_dir == dir_grad_1);
  }
  set_num_threads(0);
}

}  // namespace

TEST_CASE("cube map: texel gradients equal a plain per-texel sum in sample order bit for bit, for 1, 2 and 8 threads",
          "[raster][cube]") {
  const CubeFilter filters[] = {CubeFilter::Nearest, CubeFilter::Bilinear, CubeFilter::LinearMipmapNearest,
                                CubeFilter::Trilinear};
  // Level 0's taps are listed by piece where the lists (16 bytes a tap, 4
  // taps a sample) stay below its double sums (6 S^2 3 x 8 bytes), so the
  // fewer samples (9 more are added) take the lists, the 400 the sums.
  for (const auto& [S, few] : {std::pair<int, int>{5, 40}, std::pair<int, int>{8, 100}})
    for (int n : {few, 400})
      for (CubeFilter f : filters)
        for (int max_level : {-1, 1, 0}) {
          if (!is_mipmapped(f) && max_level != -1) continue;
          for (int mode = 0; mode < (is_mipmapped(f) ? 3 : 1); ++mode) {  // footprint, bias, both
            INFO("S " << S << ", " << n << " samples, filter " << int(f) << ", max level " << max_level << ", mode "
                      << mode);
            check_texel_gradient_bits<float>(S, max_level, f, mode != 1, mode != 0, n);
            check_texel_gradient_bits<double>(S, max_level, f, mode != 1, mode != 0, n);
          }
        }
}

TEST_CASE("cube map: texel gradients of 64 x 64 faces (several level-0 pieces) equal the plain per-texel sum",
          "[raster][cube]") {
  check_texel_gradient_bits<float>(64, -1, CubeFilter::Trilinear, true, true, 3000);
  check_texel_gradient_bits<double>(64, -1, CubeFilter::Trilinear, true, false, 3000);
  check_texel_gradient_bits<float>(64, -1, CubeFilter::Bilinear, false, false, 3000);
}
