// The vertex weld of the edge topology in two steps (raster/edge_weld.h):
// weld_vertices names each row's vertices by the smallest index, -0 with +0;
// weld_holds accepts exactly the naming weld_vertices would give; and the
// welded build is build_edge_topology's, neighbour for neighbour.
#include <catch2/catch.hpp>

#include <cstdint>
#include <random>
#include <vector>

#include "raster/antialias.h"
#include "raster/edge_weld.h"

using namespace gr::raster;

TEST_CASE("weld_vertices names equal rows by their smallest index and takes -0 for +0", "[raster][antialias]") {
  const std::vector<float> rows = {1, 2,  /* 0 */ 0, 5,   /* 1 */ 1, 2,  /* 2 */ -0.0f, 5, /* 3 */
                                   1, -2, /* 4 */ 0, 5.5f /* 5 */};
  CHECK(weld_vertices(rows.data(), 6, 2) == std::vector<std::int32_t>{0, 1, 0, 1, 4, 5});
  CHECK(weld_vertices(static_cast<const float*>(nullptr), 3, 2) == std::vector<std::int32_t>{0, 1, 2});
}

TEST_CASE("weld_holds accepts exactly the naming weld_vertices gives", "[raster][antialias]") {
  std::mt19937 rng(7);
  const double values[] = {-0.0, 0.0, 1.0, 2.0};
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 12), dims = 1 + static_cast<int>(rng() % 3);
    std::vector<double> rows(static_cast<std::size_t>(n * dims)), other(rows.size());
    for (auto& x : rows) x = values[rng() % 4];
    for (auto& x : other) x = values[rng() % 4];
    const std::vector<std::int32_t> weld = weld_vertices(rows.data(), n, dims);
    REQUIRE(weld_holds(rows.data(), dims, weld));
    // Other rows: held exactly when they weld the same.
    REQUIRE(weld_holds(other.data(), dims, weld) == (weld_vertices(other.data(), n, dims) == weld));
  }
  const std::vector<double> rows = {3, 3, 4};
  CHECK(weld_holds(rows.data(), 1, {0, 0, 2}));
  CHECK_FALSE(weld_holds(rows.data(), 1, {1, 1, 2}));  // named by the larger index
  CHECK_FALSE(weld_holds(rows.data(), 1, {0, 1, 2}));  // two names for one row
  CHECK_FALSE(weld_holds(rows.data(), 1, {0, 0, 0}));  // one name for two rows
  CHECK_FALSE(weld_holds(rows.data(), 1, {0, 2, 2}));  // a name that names another
  CHECK(weld_holds(static_cast<const double*>(nullptr), 1, {0, 1, 2}));
  CHECK_FALSE(weld_holds(static_cast<const double*>(nullptr), 1, {0, 0, 2}));
}

TEST_CASE("the welded build gives build_edge_topology's neighbours", "[raster][antialias]") {
  // Two triangles with duplicated seam vertices (rows 1 = 3, 2 = 4): welded, they share an edge.
  const std::vector<std::int32_t> tris = {0, 1, 2, 3, 5, 4};
  const std::vector<float> rows = {0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 1, 1};
  const EdgeTopology direct = build_edge_topology(tris.data(), 2, 6, rows.data(), 2);
  const EdgeTopology welded = build_edge_topology_welded(tris.data(), 2, weld_vertices(rows.data(), 6, 2));
  CHECK(welded.neighbour() == direct.neighbour());
  CHECK(welded.neighbour()[0] == 3 * 1 + 1);  // triangle 0's edge 1-2 is triangle 1's edge 4-3 (opposite slot 1)
  CHECK(welded.serial() != direct.serial());
}
