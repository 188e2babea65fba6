// TriangleGroups (raster/detail/triangle_groups.h): a G-buffer's grouping by triangle
// derived from its fragments' grouping equals the grouping of its pixels, is
// used only for the buffer the fragments came from, and recycled buffers
// give the same groupings.
#include <catch2/catch.hpp>

#include <memory>
#include <random>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/corner_gather.h"
#include "raster/detail/triangle_groups.h"

using namespace gr;
using namespace gr::raster;

namespace {

constexpr std::int64_t kTris = 300;

// An image's triangle ids (0 = background, about 40%) and its fragments.
struct Image {
  std::vector<std::int32_t> id, pixel_index, frag_id;
  Image(std::int64_t pixels, unsigned seed) {
    std::mt19937 rng(seed);
    for (std::int64_t p = 0; p < pixels; ++p) {
      id.push_back(rng() % 5 < 2 ? 0 : 1 + static_cast<std::int32_t>(rng() % kTris));
      if (id.back()) {
        pixel_index.push_back(static_cast<std::int32_t>(p));
        frag_id.push_back(id.back());
      }
    }
  }
  std::int64_t pixels() const { return static_cast<std::int64_t>(id.size()); }
  std::int64_t fragments() const { return static_cast<std::int64_t>(frag_id.size()); }
};

// The image's pixels grouped directly.
detail::Buckets direct(const Image& im) {
  detail::Buckets b;
  detail::bucket_items(im.pixels(), kTris, [&](std::int64_t i) -> std::int64_t { return im.id[i] - 1; }, &b);
  return b;
}

bool same(const detail::Buckets& a, const detail::Buckets& b) {
  return a.start == b.start && a.item == b.item && a.nonempty == b.nonempty;
}

// The fragments' groups of `im`, grouped.
std::shared_ptr<TriangleGroups> grouped_fragments(const Image& im) {
  auto g = std::make_shared<TriangleGroups>(im.frag_id.data(), nullptr);
  REQUIRE(g->by_triangle(im.frag_id.data(), im.fragments(), kTris) != nullptr);
  return g;
}

}  // namespace

TEST_CASE("triangle groups: a G-buffer grouped from its fragments' grouping equals its pixels grouped",
          "[raster][triangle_groups]") {
  for (int threads : {1, 2}) {
    INFO(threads << " threads");
    set_num_threads(threads);
    const Image im(100003, 1);
    TriangleGroups gbuffer(im.id.data(), nullptr);
    gbuffer.set_fragments(im.id.data(), grouped_fragments(im), im.pixel_index.data(), im.fragments(), nullptr);
    const detail::Buckets* b = gbuffer.by_triangle(im.id.data(), im.pixels(), kTris);
    REQUIRE(b != nullptr);
    CHECK(same(*b, direct(im)));
    // Another triangle count: not this grouping.
    CHECK(gbuffer.by_triangle(im.id.data(), im.pixels(), kTris + 1) == nullptr);
  }
  set_num_threads(0);
}

TEST_CASE("triangle groups: fragments of another buffer, grouped in part or not yet, are not used",
          "[raster][triangle_groups]") {
  const Image im(5000, 2), other(5000, 3);
  SECTION("fragments registered for another buffer are ignored") {
    TriangleGroups gbuffer(im.id.data(), nullptr);
    gbuffer.set_fragments(other.id.data(), grouped_fragments(other), other.pixel_index.data(), other.fragments(),
                          nullptr);
    CHECK(same(*gbuffer.by_triangle(im.id.data(), im.pixels(), kTris), direct(im)));
  }
  SECTION("fragments registered for this buffer are used (shown with another image's fragments)") {
    TriangleGroups gbuffer(im.id.data(), nullptr);
    gbuffer.set_fragments(im.id.data(), grouped_fragments(other), other.pixel_index.data(), other.fragments(), nullptr);
    CHECK(same(*gbuffer.by_triangle(im.id.data(), im.pixels(), kTris), direct(other)));
  }
  SECTION("fragments grouped over fewer items than registered: the pixels are grouped") {
    auto fragments = std::make_shared<TriangleGroups>(other.frag_id.data(), nullptr);
    REQUIRE(fragments->by_triangle(other.frag_id.data(), other.fragments() / 2, kTris) != nullptr);
    TriangleGroups gbuffer(im.id.data(), nullptr);
    gbuffer.set_fragments(im.id.data(), fragments, other.pixel_index.data(), other.fragments(), nullptr);
    CHECK(same(*gbuffer.by_triangle(im.id.data(), im.pixels(), kTris), direct(im)));
  }
  SECTION("fragments not yet grouped: the pixels are grouped") {
    auto fragments = std::make_shared<TriangleGroups>(other.frag_id.data(), nullptr);
    TriangleGroups gbuffer(im.id.data(), nullptr);
    gbuffer.set_fragments(im.id.data(), fragments, other.pixel_index.data(), other.fragments(), nullptr);
    CHECK(same(*gbuffer.by_triangle(im.id.data(), im.pixels(), kTris), direct(im)));
  }
}

TEST_CASE("triangle groups: recycled buffers give the same groupings, smaller after larger",
          "[raster][triangle_groups]") {
  const Image large(60000, 4), small(777, 5);
  { TriangleGroups g(large.id.data(), nullptr); REQUIRE(g.by_triangle(large.id.data(), large.pixels(), kTris)); }
  {
    TriangleGroups g(small.id.data(), nullptr);
    CHECK(same(*g.by_triangle(small.id.data(), small.pixels(), kTris), direct(small)));
  }
  {
    TriangleGroups g(small.id.data(), nullptr);
    g.set_fragments(small.id.data(), grouped_fragments(small), small.pixel_index.data(), small.fragments(), nullptr);
    CHECK(same(*g.by_triangle(small.id.data(), small.pixels(), kTris), direct(small)));
  }
}

TEST_CASE("triangle groups: the corners grouped by vertex once are the grouping of the used triangles' rows, "
          "and are refused for other rows or another vertex count",
          "[raster][triangle_groups]") {
  const Image im(400, 6);  // about 240 covered pixels over 300 triangles: some triangles uncovered
  constexpr std::int64_t kVertices = 200;
  std::mt19937 rng(7);
  std::vector<std::int32_t> tris(3 * kTris);
  for (std::int32_t& v : tris) v = static_cast<std::int32_t>(rng() % kVertices);
  TriangleGroups g(im.id.data(), nullptr);
  // Not before the pixels are grouped by triangle.
  CHECK(g.corners_by_vertex(im.id.data(), tris.data(), kTris, kVertices) == nullptr);
  const detail::Buckets* by_tri = g.by_triangle(im.id.data(), im.pixels(), kTris);
  REQUIRE(by_tri != nullptr);
  const detail::Buckets* corners = g.corners_by_vertex(im.id.data(), tris.data(), kTris, kVertices);
  REQUIRE(corners != nullptr);
  detail::Buckets expected;
  detail::group_corners(tris.data(), by_tri->nonempty.data(), static_cast<std::int64_t>(by_tri->nonempty.size()),
                        nullptr, kVertices, &expected);
  CHECK(same(*corners, expected));
  // The same rows again (another copy): the same grouping.
  const std::vector<std::int32_t> copy = tris;
  CHECK(g.corners_by_vertex(im.id.data(), copy.data(), kTris, kVertices) == corners);
  // A used triangle's row changed, another vertex count, another buffer: refused.
  std::vector<std::int32_t> changed = tris;
  const std::int64_t t = by_tri->nonempty.back();
  changed[3 * t + 1] = (changed[3 * t + 1] + 1) % kVertices;
  CHECK(g.corners_by_vertex(im.id.data(), changed.data(), kTris, kVertices) == nullptr);
  CHECK(g.corners_by_vertex(im.id.data(), tris.data(), kTris, kVertices + 1) == nullptr);
  CHECK(g.corners_by_vertex(copy.data(), tris.data(), kTris, kVertices) == nullptr);
  // A row no pixel covers does not matter.
  std::vector<bool> covered(kTris, false);
  for (std::int32_t u : by_tri->nonempty) covered[u] = true;
  std::int64_t uncovered = 0;
  while (uncovered < kTris && covered[uncovered]) ++uncovered;
  REQUIRE(uncovered < kTris);
  std::vector<std::int32_t> other = tris;
  other[3 * uncovered] = (other[3 * uncovered] + 1) % kVertices;
  CHECK(g.corners_by_vertex(im.id.data(), other.data(), kTris, kVertices) == corners);
}
