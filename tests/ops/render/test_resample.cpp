#include <catch2/catch.hpp>

#include "ops/ops.h"
#include "ops/render/resample.h"
#include "test_support.h"

using namespace gr;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

TEST_CASE("downsample_box: each output pixel is the mean of its block", "[ops][resample]") {
  // 4 x 6 x 2 with value 100 y + 10 x + c: block (Y, X) of a factor-2 resample has mean
  // 100 (2Y + 0.5) + 10 (2X + 0.5) + c.
  std::vector<double> v;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x)
      for (int c = 0; c < 2; ++c) v.push_back(100 * y + 10 * x + c);
  for (DType dtype : {DType::Float64, DType::Float32}) {
    const Tensor out = downsample_box(Tensor::from_values(v, {4, 6, 2}, dtype), 2);
    REQUIRE(out.shape() == Shape({2, 3, 2}));
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x)
        for (int c = 0; c < 2; ++c) CHECK(out.at({y, x, c}) == Approx(100 * (2 * y + 0.5) + 10 * (2 * x + 0.5) + c));
  }
  const Tensor one = Tensor::uniform({3, 5, 1}, 0, 1, 7, DType::Float64);
  CHECK(downsample_box(one, 1).to_vector() == one.to_vector());
}

TEST_CASE("downsample_box: gradient matches finite differences", "[ops][resample][gradcheck]") {
  for (int factor : {1, 2, 3}) {
    Tensor image = random_input({3 * factor, 2 * factor, 3}, -1, 1, 40 + factor);
    require_gradcheck("downsample_box x" + std::to_string(factor),
                      [factor](const Inputs& in) { return downsample_box(in[0], factor); }, {image});
  }
  // Whole image into one pixel, one channel, and a factor with an uneven block walk (5).
  require_gradcheck("downsample_box 1 pixel", [](const Inputs& in) { return downsample_box(in[0], 4); },
                    {random_input({4, 4, 1}, 0, 2, 44)});
  require_gradcheck("downsample_box x5", [](const Inputs& in) { return downsample_box(in[0], 5); },
                    {random_input({10, 15, 2}, -3, 3, 45)});
  // Composed with a nonlinear function so that the incoming gradient varies per pixel.
  require_gradcheck("downsample_box in a loss",
                    [](const Inputs& in) { return sum(pow(downsample_box(in[0] * in[0], 2), 3.0)); },
                    {random_input({6, 8, 2}, -1, 1, 46)});
}

TEST_CASE("downsample_box: bad input throws naming the argument", "[ops][resample][errors]") {
  CHECK_THROWS_AS(downsample_box(Tensor::ones({4, 4, 3}), 0), ValueError);
  CHECK_THROWS_WITH(downsample_box(Tensor::ones({4, 4, 3}), 0), Catch::Contains("factor"));
  CHECK_THROWS_AS(downsample_box(Tensor::ones({4, 6, 3}), 4), ShapeError);
  CHECK_THROWS_WITH(downsample_box(Tensor::ones({4, 6, 3}), 4), Catch::Contains("image"));
  CHECK_THROWS_AS(downsample_box(Tensor::ones({4, 4}), 2), ShapeError);
  CHECK_THROWS_AS(downsample_box(Tensor::zeros({4, 4, 1}, DType::Int32), 2), DTypeError);
  CHECK_THROWS_AS(downsample_box(Tensor(), 2), Error);
}

TEST_CASE("downsample_box: output and gradient are bit-identical for 1 and 2 threads", "[ops][resample][determinism]") {
  auto run = [](int threads, DType dtype) {
    set_num_threads(threads);
    Tensor image = cast(Tensor::uniform({256, 192, 3}, 0, 1, 47, DType::Float64), dtype).set_requires_grad();
    Tensor out = downsample_box(image, 4);
    backward(sum(out * out));
    std::vector<double> r = out.to_vector();
    for (double x : image.grad().to_vector()) r.push_back(x);
    return r;
  };
  for (DType dtype : {DType::Float64, DType::Float32}) CHECK(run(1, dtype) == run(2, dtype));
  set_num_threads(0);
}
