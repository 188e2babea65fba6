// The value checks both front ends call (raster/mesh_checks.h): triangle
// indices, finite positions, G-buffer ids (int32 and nvdiffrast's float
// channel) and image sizes; each error names the op, the argument and the
// first bad element, the same one for 1, 2 and 8 threads.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "raster/mesh_checks.h"

using namespace gr;
using namespace gr::raster::detail;
using gr::raster::kMaxSide;

namespace {

// The message of the E that f throws ("" and a failure when none).
template <class E, class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  FAIL("no exception of the expected type");
  return "";
}

}  // namespace

TEST_CASE("mesh checks: a triangle index outside 0..N-1 names the triangle, the corner and the index",
          "[raster][mesh_checks][errors]") {
  std::vector<std::int32_t> tris = {0, 1, 2, 2, 1, 3};
  CHECK_NOTHROW(check_triangles(tris.data(), 2, 4, "op"));
  tris[4] = 4;
  CHECK(error_of<IndexError>([&] { check_triangles(tris.data(), 2, 4, "op"); }) ==
        "op: tris[1][1] = 4 is outside [0, 4)");
  tris[4] = -1;
  CHECK(error_of<IndexError>([&] { check_triangles(tris.data(), 2, 4, "op"); }) ==
        "op: tris[1][1] = -1 is outside [0, 4)");
  CHECK(error_of<ValueError>([&] { check_triangles(tris.data(), -1, 4, "op"); }).find("negative") !=
        std::string::npos);
}

TEST_CASE("mesh checks: the first bad index, NaN or id is reported whatever the thread count",
          "[raster][mesh_checks][determinism]") {
  // Bad elements in several of the scan's blocks: the lowest one is named.
  const std::int64_t M = 200000;
  std::vector<std::int32_t> tris(3 * M, 0);
  std::vector<double> pos(4 * M, 1.0);
  std::vector<std::int32_t> ids(3 * M, 1);
  for (std::int64_t i : {std::int64_t(500000), std::int64_t(150001), std::int64_t(70000)}) {
    tris[i] = 9;
    pos[i] = std::numeric_limits<double>::quiet_NaN();
    ids[i] = -3;
  }
  for (int threads : {1, 2, 8}) {
    set_num_threads(threads);
    CHECK(error_of<IndexError>([&] { check_triangles(tris.data(), M, 5, "op"); }) ==
          "op: tris[23333][1] = 9 is outside [0, 5)");
    CHECK(error_of<ValueError>([&] { check_finite(pos.data(), 4 * M, "pos", "op"); }) ==
          "op: pos[70000] is NaN or Inf");
    CHECK(error_of<IndexError>([&] { check_tri_ids(ids.data(), 3 * M, 4, "op"); }) ==
          "op: tri_id[70000] = -3 is outside [0, 4]");
  }
  set_num_threads(0);
}

TEMPLATE_TEST_CASE("mesh checks: NaN and Inf positions are refused naming the argument and the element",
                   "[raster][mesh_checks][errors]", float, double) {
  std::vector<TestType> pos(12, TestType(0.5));
  CHECK_NOTHROW(check_finite(pos.data(), 12, "pos", "op"));
  pos[9] = std::numeric_limits<TestType>::infinity();
  CHECK(error_of<ValueError>([&] { check_finite(pos.data(), 12, "pos", "op"); }) == "op: pos[9] is NaN or Inf");
  pos[9] = -std::numeric_limits<TestType>::infinity();
  pos[6] = std::numeric_limits<TestType>::quiet_NaN();
  CHECK(error_of<ValueError>([&] { check_finite(pos.data(), 12, "clip", "op"); }) == "op: clip[6] is NaN or Inf");
}

TEST_CASE("mesh checks: G-buffer ids outside [0, M] are refused naming the pixel", "[raster][mesh_checks][errors]") {
  std::vector<std::int32_t> ids = {0, 3, 1, 2};
  CHECK_NOTHROW(check_tri_ids(ids.data(), 4, 3, "op"));
  ids[2] = 4;
  CHECK(error_of<IndexError>([&] { check_tri_ids(ids.data(), 4, 3, "op"); }) == "op: tri_id[2] = 4 is outside [0, 3]");
}

TEMPLATE_TEST_CASE("mesh checks: an nvdiffrast G-buffer id that is not an integer in [0, M] names the pixel",
                   "[raster][mesh_checks][errors]", float, double) {
  // [pixels, 4]: (u, v, z/w, id + 1); only channel 3 is checked.
  std::vector<TestType> rast = {0.5, 0.5, 2.0, 1, -1, 7, 0.3, 0, 0, 0, 0, 3};
  CHECK_NOTHROW(check_rast_ids(rast.data(), 3, 3, "rast", "op"));
  for (TestType bad : {TestType(4), TestType(-1), TestType(1.5), std::numeric_limits<TestType>::quiet_NaN()}) {
    rast[7] = bad;
    const std::string msg = error_of<IndexError>([&] { check_rast_ids(rast.data(), 3, 3, "rast", "op"); });
    INFO(msg);
    CHECK(msg.rfind("op: rast[..., 3] (triangle id + 1) at pixel 1 is ", 0) == 0);
    CHECK(msg.find("not an integer in [0, 3]") != std::string::npos);
  }
}

TEST_CASE("mesh checks: image sizes outside 1..kMaxSide per side are refused before anything is allocated",
          "[raster][mesh_checks][errors]") {
  CHECK(kMaxSide == 16384);
  CHECK_NOTHROW(check_image_size(1, 1, "op"));
  CHECK_NOTHROW(check_image_size(kMaxSide, kMaxSide, "op"));  // 2^28 pixels, the most
  CHECK(error_of<ValueError>([&] { check_image_size(0, 16, "op"); }) ==
        "op: image size 0 x 16 is outside 1..16384 per side (at most 2^28 pixels)");
  for (const auto& size : {std::pair<std::int64_t, std::int64_t>{kMaxSide + 1, 8}, {8, kMaxSide + 1}, {-3, 8},
                           {INT64_MAX, INT64_MAX}, {std::int64_t(1) << 32, std::int64_t(1) << 32}})
    CHECK(error_of<ValueError>([&] { check_image_size(size.first, size.second, "op"); }).find("image size") !=
          std::string::npos);
}
