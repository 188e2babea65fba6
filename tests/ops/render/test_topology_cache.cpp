// The welded topology antialias keeps between calls (ops/render/topology_cache.h):
// the same object while the triangles are unwritten and the weld holds, and
// always the neighbours a fresh build_edge_topology gives: when welded
// vertices come apart, when distinct ones come to coincide (-0 and +0 among
// them), when the triangles are written in place, in random sequences of
// such changes, from several threads at once, and through antialias and
// antialias_batch.
#include <catch2/catch.hpp>

#include <cstdint>
#include <random>
#include <thread>
#include <vector>

#include "ops/ops.h"
#include "ops/render/topology_cache.h"
#include "raster/antialias.h"
#include "raster/procedural.h"

using namespace gr;

namespace {

// An icosphere as a triangle soup: every corner its own vertex, its clip row
// (x, y, z, 1) from the sphere's shared vertex, so the weld closes the mesh.
struct Soup {
  Tensor triangles;          // [M, 3]: 0, 1, 2, ...
  std::vector<double> rows;  // 3M x 4
  std::int64_t vertices() const { return static_cast<std::int64_t>(rows.size() / 4); }
};

Soup icosphere_soup(int subdivisions) {
  const raster::Mesh mesh = raster::make_icosphere(subdivisions, 0.6f);
  const Tensor& tris = mesh.triangles;
  const Tensor& pos = mesh.positions;
  const std::int64_t m = tris.size(0);
  Soup s;
  std::vector<std::int32_t> soup(static_cast<std::size_t>(3 * m));
  for (std::int64_t c = 0; c < 3 * m; ++c) {
    soup[c] = static_cast<std::int32_t>(c);
    const std::int32_t v = tris.data<std::int32_t>()[c];
    for (int d = 0; d < 3; ++d) s.rows.push_back(pos.data<float>()[3 * v + d]);
    s.rows.push_back(1.0);
  }
  s.triangles = Tensor::from_vector<std::int32_t>(soup, {m, 3});
  return s;
}

// The topology the op keeps, and the one built afresh for the same input.
AntialiasTopology kept(const Tensor& triangles, const std::vector<double>& rows) {
  return detail::welded_topology(triangles, static_cast<std::int64_t>(rows.size() / 4), rows.data());
}
std::vector<std::int64_t> fresh(const Tensor& triangles, const std::vector<double>& rows) {
  return raster::build_edge_topology(triangles.data<std::int32_t>(), triangles.size(0),
                                     static_cast<std::int64_t>(rows.size() / 4), rows.data(), 4)
      .neighbour();
}

// Corners of the soup sharing vertex `corner`'s row.
std::vector<std::int64_t> copies_of(const Soup& s, std::int64_t corner) {
  std::vector<std::int64_t> out;
  for (std::int64_t v = 0; v < s.vertices(); ++v)
    if (std::equal(s.rows.begin() + 4 * v, s.rows.begin() + 4 * v + 4, s.rows.begin() + 4 * corner)) out.push_back(v);
  return out;
}

}  // namespace

TEST_CASE("the kept topology is the same object while the weld holds and equals a fresh build",
          "[ops][antialias][topology_cache]") {
  const Soup s = icosphere_soup(1);
  const AntialiasTopology first = kept(s.triangles, s.rows);
  CHECK(first->neighbour() == fresh(s.triangles, s.rows));
  // Moved as a whole (the same vertices coincide): the same object.
  std::vector<double> moved = s.rows;
  for (std::int64_t v = 0; v < s.vertices(); ++v) moved[4 * v] += 0.125;
  const AntialiasTopology again = kept(s.triangles, moved);
  CHECK(again == first);
  CHECK(again->serial() == first->serial());
  CHECK(again->neighbour() == fresh(s.triangles, moved));
}

TEST_CASE("the kept topology is rebuilt when welded vertices come apart and found again when they rejoin",
          "[ops][antialias][topology_cache]") {
  const Soup s = icosphere_soup(1);
  const AntialiasTopology closed = kept(s.triangles, s.rows);
  std::vector<double> torn = s.rows;
  const std::vector<std::int64_t> copies = copies_of(s, 0);
  REQUIRE(copies.size() >= 5);  // an icosphere vertex is in 5 or 6 triangles
  torn[4 * copies[1] + 2] += 0.01;
  const AntialiasTopology open = kept(s.triangles, torn);
  CHECK(open != closed);
  CHECK(open->neighbour() == fresh(s.triangles, torn));
  CHECK(open->neighbour() != closed->neighbour());
  // Both welds are kept: rejoined, the first object comes back.
  const AntialiasTopology rejoined = kept(s.triangles, s.rows);
  CHECK(rejoined == closed);
  CHECK(rejoined->neighbour() == fresh(s.triangles, s.rows));
  CHECK(kept(s.triangles, torn) == open);
}

TEST_CASE("the kept topology is rebuilt when distinct vertices come to coincide", "[ops][antialias][topology_cache]") {
  const Soup s = icosphere_soup(1);
  const AntialiasTopology before = kept(s.triangles, s.rows);
  // Every copy of corner 0's vertex moved onto corner 1's: edge 0-1 collapses (non-manifold).
  std::vector<double> merged = s.rows;
  for (std::int64_t v : copies_of(s, 0))
    for (int d = 0; d < 4; ++d) merged[4 * v + d] = s.rows[4 + d];
  const AntialiasTopology after = kept(s.triangles, merged);
  CHECK(after != before);
  CHECK(after->neighbour() == fresh(s.triangles, merged));
  CHECK(after->neighbour() != before->neighbour());
  // Only one copy onto another vertex: no longer one class, not yet the other.
  std::vector<double> one = s.rows;
  for (int d = 0; d < 4; ++d) one[4 * copies_of(s, 0)[2] + d] = s.rows[4 + d];
  CHECK(kept(s.triangles, one)->neighbour() == fresh(s.triangles, one));
}

TEST_CASE("the kept topology welds -0 with +0 as a fresh build does", "[ops][antialias][topology_cache]") {
  Soup s = icosphere_soup(1);
  const std::vector<std::int64_t> copies = copies_of(s, 0);
  for (std::int64_t v : copies) s.rows[4 * v] = 0.0;
  const AntialiasTopology plus = kept(s.triangles, s.rows);
  std::vector<double> minus = s.rows;
  minus[4 * copies[1]] = -0.0;  // == +0.0: the same weld
  const AntialiasTopology signed_zero = kept(s.triangles, minus);
  CHECK(signed_zero == plus);
  CHECK(signed_zero->neighbour() == fresh(s.triangles, minus));
  // A vertex elsewhere at -0 where one of the class sits at +0 joins it.
  std::vector<double> joined = minus;
  for (int d = 0; d < 4; ++d) joined[4 * copies_of(s, 5)[0] + d] = d == 0 ? -0.0 : s.rows[4 * copies[0] + d];
  CHECK(kept(s.triangles, joined)->neighbour() == fresh(s.triangles, joined));
}

TEST_CASE("the kept topology is rebuilt when the triangle list is written in place", "[ops][antialias][topology_cache]") {
  const Soup s = icosphere_soup(1);
  Tensor tris = s.triangles.copy();
  const AntialiasTopology before = kept(tris, s.rows);
  // Triangle 0 turned into a copy of triangle 1's corners (the non-const data() counts the write).
  std::int32_t* t = tris.data<std::int32_t>();
  for (int k = 0; k < 3; ++k) t[k] = t[3 + k];
  const AntialiasTopology after = kept(tris, s.rows);
  CHECK(after != before);
  CHECK(after->neighbour() == fresh(tris, s.rows));
  CHECK(after->neighbour() != before->neighbour());
  // Another tensor with the same values: its own entry, the same neighbours.
  const AntialiasTopology other = kept(tris.copy(), s.rows);
  CHECK(other != after);
  CHECK(other->neighbour() == after->neighbour());
}

TEST_CASE("the kept topology equals a fresh build over random sequences of welds, rows and writes",
          "[ops][antialias][topology_cache]") {
  // A small soup whose rows take few values (-0 and +0 among them), so that
  // classes merge and split at random.
  std::mt19937 rng(33);
  const std::int64_t m = 24, n = 30;
  std::vector<std::int32_t> list(static_cast<std::size_t>(3 * m));
  for (auto& i : list) i = static_cast<std::int32_t>(rng() % n);
  Tensor tris = Tensor::from_vector<std::int32_t>(list, {m, 3});
  const double values[] = {-0.0, 0.0, 0.5, -1.0};
  std::vector<double> rows(static_cast<std::size_t>(4 * n));
  for (auto& x : rows) x = values[rng() % 4];
  AntialiasTopology last;
  int reused = 0;
  for (int step = 0; step < 300; ++step) {
    switch (rng() % 4) {
      case 0:  // one row anew
      {
        const std::size_t v = rng() % n;
        for (int d = 0; d < 4; ++d) rows[4 * v + d] = values[rng() % 4];
        break;
      }
      case 1:  // one component's sign of zero
      {
        double& x = rows[rng() % rows.size()];
        if (x == 0) x = -x;
        break;
      }
      case 2:  // one row onto another's
      {
        const std::size_t a = rng() % n, b = rng() % n;
        for (int d = 0; d < 4; ++d) rows[4 * a + d] = rows[4 * b + d];
        break;
      }
      default:  // one index rewritten in place, or nothing
        if (rng() % 4 == 0) tris.data<std::int32_t>()[rng() % (3 * m)] = static_cast<std::int32_t>(rng() % n);
    }
    const AntialiasTopology t = kept(tris, rows);
    REQUIRE(t->neighbour() == fresh(tris, rows));
    reused += t == last;
    last = t;
  }
  CHECK(reused > 0);
}

TEST_CASE("the kept topology is right from several threads at once", "[ops][antialias][topology_cache]") {
  const Soup s = icosphere_soup(2);
  std::vector<double> torn = s.rows;
  torn[4 * copies_of(s, 7)[1] + 1] += 0.02;
  const std::vector<std::int64_t> closed = fresh(s.triangles, s.rows), open = fresh(s.triangles, torn);
  std::vector<int> right(4, 0);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] {
      for (int k = 0; k < 20; ++k) {
        const bool odd = (i + k) % 2 != 0;
        right[i] += kept(s.triangles, odd ? torn : s.rows)->neighbour() == (odd ? open : closed);
      }
    });
  for (auto& t : threads) t.join();
  CHECK(right == std::vector<int>(4, 20));
}

TEST_CASE("antialias and antialias_batch without a topology give the results of a fresh welded topology",
          "[ops][antialias][topology_cache]") {
  // The soup in clip space (w = 1), drawn at 40 x 32, torn open in one call:
  // each call's result must be that of the topology welded from its rows.
  const Soup s = icosphere_soup(2);
  const std::int64_t n = s.vertices();
  std::vector<double> torn = s.rows;
  for (std::int64_t v : copies_of(s, 0)) torn[4 * v] += v % 2 ? 0.05 : 0.0;
  const Tensor colours = Tensor::uniform({n, 3}, 0, 1, 5, DType::Float64);
  auto render = [&](const std::vector<double>& rows, bool given) {
    const Tensor clip = Tensor::from_vector<double>(rows, {n, 4});
    const GBuffer gb = rasterize(clip, s.triangles, {40, 32});
    AntialiasOptions o;
    if (given) o.topology = antialias_topology(s.triangles, clip);
    return antialias(interpolate(colours, gb, s.triangles), gb, clip, s.triangles, o).to_vector();
  };
  for (int call = 0; call < 4; ++call) {
    const std::vector<double>& rows = call % 2 ? torn : s.rows;
    CHECK(render(rows, false) == render(rows, true));
  }
  // A batch of the two states, each image welded by its own rows.
  std::vector<double> both = s.rows;
  both.insert(both.end(), torn.begin(), torn.end());
  const Tensor clip = Tensor::from_vector<double>(both, {2, n, 4});
  const GBuffer gb = rasterize_batch(clip, s.triangles, {40, 32});
  const Tensor image = interpolate_batch(colours, gb, s.triangles);
  for (int call = 0; call < 2; ++call) {
    const std::vector<double> batch = antialias_batch(image, gb, clip, s.triangles).to_vector();
    const std::vector<double> closed = render(s.rows, true), open = render(torn, true);
    std::vector<double> expected = closed;
    expected.insert(expected.end(), open.begin(), open.end());
    CHECK(batch == expected);
  }
}
