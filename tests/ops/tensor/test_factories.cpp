#include <catch2/catch.hpp>

#include <limits>
#include <type_traits>

#include "ops/ops.h"

using namespace gr;

TEST_CASE("zeros_like, ones_like and full_like copy the shape and dtype and nothing else", "[ops][factories]") {
  const Tensor like = Tensor::uniform({2, 3}, 0, 1, 1, DType::Float64).set_requires_grad();
  for (const Tensor& t : {zeros_like(like), ones_like(like), full_like(like, 2.5)}) {
    CHECK(t.shape() == like.shape());
    CHECK(t.dtype() == DType::Float64);
    CHECK_FALSE(t.requires_grad());
  }
  CHECK(zeros_like(like).to_vector() == std::vector<double>(6, 0.0));
  CHECK(ones_like(like).to_vector() == std::vector<double>(6, 1.0));
  CHECK(full_like(like, 2.5).to_vector() == std::vector<double>(6, 2.5));
  CHECK(zeros_like(Tensor::ones({4}, DType::Int32)).dtype() == DType::Int32);
  CHECK_THROWS_AS(ones_like(Tensor()), ValueError);
}

TEST_CASE("index tensors come from uint32 and int64 arrays, checked against the int32 range", "[ops][factories]") {
  const Tensor t = triangle_indices(std::vector<std::uint32_t>{0, 1, 2, 2, 1, 3});
  CHECK(t.dtype() == DType::Int32);
  CHECK(t.shape() == Shape{2, 3});
  CHECK(t.to_vector() == std::vector<double>{0, 1, 2, 2, 1, 3});
  const Tensor big = index_tensor(std::vector<std::int64_t>{0, std::numeric_limits<std::int32_t>::max()}, {2});
  CHECK(big.at({1}) == std::numeric_limits<std::int32_t>::max());
  // The first value out of range is named with its position.
  CHECK_THROWS_WITH(index_tensor(std::vector<std::uint32_t>{0, 1, 2147483648u, 4}, {4}),
                    Catch::Contains("value 2147483648 at position 2"));
  CHECK_THROWS_AS(index_tensor(std::vector<std::uint32_t>{0, 1, 2147483648u, 4}, {4}), IndexError);
  CHECK_THROWS_WITH(triangle_indices(std::vector<std::int64_t>{0, 1, -1}), Catch::Contains("value -1 at position 2"));
  CHECK_THROWS_AS(triangle_indices(std::vector<std::int64_t>{0, 1, std::int64_t(1) << 40}), IndexError);
  CHECK_THROWS_AS(triangle_indices(std::vector<std::uint32_t>{0, 1, 2, 3}), ShapeError);
  CHECK_THROWS_AS(index_tensor(std::vector<std::uint32_t>{0, 1, 2}, {2, 2}), ShapeError);
}

TEST_CASE("channel picks one channel of the last axis and keeps the axis", "[ops][channel]") {
  const Tensor rgba = Tensor::from_values({1, 2, 3, 4, 5, 6, 7, 8}, {2, 4});
  CHECK(channel(rgba, 3).shape() == Shape{2, 1});
  CHECK(channel(rgba, 3).to_vector() == std::vector<double>{4, 8});
  CHECK(channel(rgba, -4).to_vector() == std::vector<double>{1, 5});
  CHECK((slice(rgba, 1, 0, 3) * channel(rgba, 3)).shape() == Shape{2, 3});  // broadcasts against colours
  CHECK(channel(Tensor::from_vector<std::int32_t>({7, 9}, {2}), 1).to_vector() == std::vector<double>{9});
  CHECK_THROWS_AS(channel(rgba, 4), IndexError);
  CHECK_THROWS_AS(channel(rgba, -5), IndexError);
  CHECK_THROWS_AS(channel(Tensor::scalar(1), 0), ShapeError);
}

TEST_CASE("channel's gradient reaches only the picked channel (gradcheck)", "[ops][channel][gradcheck]") {
  const Tensor a = Tensor::uniform({3, 2, 4}, -1, 1, 7, DType::Float64).set_requires_grad();
  const GradcheckResult r = gradcheck([](const std::vector<Tensor>& x) { return channel(x[0], -2) * x[0]; }, {a});
  INFO(r.report());
  CHECK(r.passed);
}

TEST_CASE("types an ops user meets are reachable in namespace gr", "[ops][exports]") {
  const GBuffer gb = rasterize(Tensor::from_values({-1, -1, 0, 1, 1, -1, 0, 1, 0, 1, 0, 1}, {3, 4}),
                               triangle_indices(std::vector<std::uint32_t>{0, 1, 2}), {4, 4});
  const RasterStats stats = gb.stats;  // was gr::raster::RasterStats only
  CHECK(stats.triangles_in == 1);
  CHECK(gb.depth.at({0, 0}) == kBackgroundDepth);
  AntialiasStats aa;
  SsrStats ssr;
  (void)aa, (void)ssr;
  CHECK(std::is_same<EdgeTopology, raster::EdgeTopology>::value);
}
