// What a call reading one image's G-buffer hands a backend
// (raster/image_on_device.h): the kept copy with the triangles it drew (a
// range's, ids made local to it) or, without a copy it may read, all the
// triangles and the host's ids; with whole_list (antialias) the copy with all
// the triangles, the host's ids and the range's first row.
#include <catch2/catch.hpp>

#include <cstdint>
#include <memory>
#include <vector>

#include "raster/image_on_device.h"

using namespace gr;

namespace {

// 5 triangles; the image's host ids index all of them (0: background).
const std::vector<std::int32_t> kTris = {0, 1, 2, 1, 2, 3, 2, 3, 4, 3, 4, 5, 4, 5, 6};
const std::vector<std::int32_t> kIds = {0, 3, 4, 0, 3};

raster::KeptImage kept(std::int64_t first, std::int64_t count) {
  return {std::make_shared<raster::DeviceGBuffer>(), first, count};
}

void check_uploads(const raster::ImageOnDevice& on) {
  CHECK(on.device == nullptr);
  CHECK(on.tris == kTris.data());
  CHECK(on.num_tris == 5);
  CHECK(on.ids() == kIds.data());
  CHECK(on.first == 0);
}

}  // namespace

TEST_CASE("image on device: without a kept copy the call gets all the triangles and the host's ids",
          "[raster][image_on_device]") {
  for (bool whole_list : {false, true}) {
    check_uploads(raster::image_on_device(nullptr, kTris.data(), 5, kIds.data(), 5, whole_list));
    const raster::KeptImage none{nullptr, 2, 3};  // the backend made no copy
    check_uploads(raster::image_on_device(&none, kTris.data(), 5, kIds.data(), 5, whole_list));
  }
}

TEST_CASE("image on device: a copy of all the triangles is read with them and the host's ids",
          "[raster][image_on_device]") {
  const raster::KeptImage whole = kept(0, 5);
  for (bool whole_list : {false, true}) {
    const raster::ImageOnDevice on = raster::image_on_device(&whole, kTris.data(), 5, kIds.data(), 5, whole_list);
    CHECK(on.device == whole.device.get());
    CHECK(on.tris == kTris.data());
    CHECK(on.num_tris == 5);
    CHECK(on.ids() == kIds.data());
    CHECK(on.first == 0);
  }
}

TEST_CASE("image on device: a range's copy is read with the range's triangles and ids local to it",
          "[raster][image_on_device]") {
  const raster::KeptImage range = kept(2, 3);
  const raster::ImageOnDevice on = raster::image_on_device(&range, kTris.data(), 5, kIds.data(), 5, false);
  CHECK(on.device == range.device.get());
  CHECK(on.tris == kTris.data() + 6);
  CHECK(on.num_tris == 3);
  CHECK(std::vector<std::int32_t>(on.ids(), on.ids() + 5) == std::vector<std::int32_t>{0, 1, 2, 0, 1});
}

TEST_CASE("image on device: a range from the first triangle keeps the host's ids", "[raster][image_on_device]") {
  const raster::KeptImage range = kept(0, 4);
  const raster::ImageOnDevice on = raster::image_on_device(&range, kTris.data(), 5, kIds.data(), 5, false);
  CHECK(on.num_tris == 4);
  CHECK(on.tris == kTris.data());
  CHECK(on.ids() == kIds.data());
}

TEST_CASE("image on device: an empty range's copy is read with no triangles", "[raster][image_on_device]") {
  const std::vector<std::int32_t> background(5, 0);
  const raster::KeptImage empty = kept(3, 0);
  const raster::ImageOnDevice on = raster::image_on_device(&empty, kTris.data(), 5, background.data(), 5, false);
  CHECK(on.device == empty.device.get());
  CHECK(on.num_tris == 0);
  CHECK(std::vector<std::int32_t>(on.ids(), on.ids() + 5) == background);
}

TEST_CASE("image on device: whole_list passes a range's copy with all the triangles, the host's ids and its first row",
          "[raster][image_on_device]") {
  for (const raster::KeptImage& range : {kept(2, 3), kept(0, 4), kept(3, 0)}) {
    const raster::ImageOnDevice on = raster::image_on_device(&range, kTris.data(), 5, kIds.data(), 5, true);
    CHECK(on.device == range.device.get());
    CHECK(on.first == range.first);
    CHECK(on.tris == kTris.data());
    CHECK(on.num_tris == 5);
    CHECK(on.ids() == kIds.data());
  }
}
