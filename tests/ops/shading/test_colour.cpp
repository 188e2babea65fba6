// sRGB transfer functions (ops/shading/colour.h): known values, the round
// trip, both branches and their thresholds under gradcheck, no NaN from the
// branch not taken, argument errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "shading_cases.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;
using Inputs = std::vector<Tensor>;

namespace {
Tensor values(const std::vector<double>& v) { return gr::testing::shading::vec(v); }
}  // namespace

TEST_CASE("srgb: 0.5 decodes to 0.21404114048223255 and the pair round-trips on both branches",
          "[ops][shading][colour]") {
  CHECK(shading::srgb_to_linear(values({0.5})).item() == Approx(0.21404114048223255).epsilon(1e-15));
  CHECK(shading::linear_to_srgb(values({0.21404114048223255})).item() == Approx(0.5).epsilon(1e-15));
  // The linear branch (x <= 0.04045, the threshold included), the power branch, values past 1 and below 0.
  const Tensor x = values({-0.3, -0.01, 0.0, 0.02, 0.04045, 0.0405, 0.3, 0.99, 1.0, 1.7});
  const Tensor linear = shading::srgb_to_linear(x);
  CHECK(linear.at({4}) == Approx(0.04045 / 12.92).epsilon(1e-15));
  CHECK(linear.at({0}) == Approx(-0.3 / 12.92).epsilon(1e-15));
  CHECK(linear.at({9}) == Approx(std::pow((1.7 + 0.055) / 1.055, 2.4)).epsilon(1e-15));
  CHECK(linear.at({8}) == Approx(1.0).epsilon(1e-15));
  const std::vector<double> back = shading::linear_to_srgb(linear).to_vector();
  for (std::size_t i = 0; i < back.size(); ++i) CHECK(back[i] == Approx(x.to_vector()[i]).margin(1e-14));
}

TEST_CASE("srgb: gradients match finite differences on random values across both branches",
          "[ops][shading][colour][gradcheck]") {
  GradcheckOptions fine;
  fine.eps = 1e-6;  // keeps x +- 2 eps on one branch
  require_gradcheck("srgb_to_linear random", [](const Inputs& in) { return shading::srgb_to_linear(in[0]); },
                    {random_input({4, 6}, -0.2, 1.5, 1)}, fine);
  require_gradcheck("linear_to_srgb random", [](const Inputs& in) { return shading::linear_to_srgb(in[0]); },
                    {random_input({4, 6}, -0.02, 2.0, 2)}, fine);
}

TEST_CASE("srgb: gradients match finite differences just below and above each threshold, and are the linear "
          "slope at it",
          "[ops][shading][colour][gradcheck]") {
  GradcheckOptions fine;
  fine.eps = 1e-8;
  for (double d : {-1e-6, 1e-6}) {
    require_gradcheck("srgb_to_linear near 0.04045",
                      [](const Inputs& in) { return shading::srgb_to_linear(in[0]); },
                      {gr::testing::shading::leaf(values({0.04045 + d}))}, fine);
    require_gradcheck("linear_to_srgb near 0.0031308",
                      [](const Inputs& in) { return shading::linear_to_srgb(in[0]); },
                      {gr::testing::shading::leaf(values({0.0031308 + d}))}, fine);
  }
  Tensor x = gr::testing::shading::leaf(values({0.04045}));
  backward(shading::srgb_to_linear(x));
  CHECK(x.grad().item() == Approx(1 / 12.92).epsilon(1e-15));
  Tensor y = gr::testing::shading::leaf(values({0.0031308}));
  backward(shading::linear_to_srgb(y));
  CHECK(y.grad().item() == Approx(12.92).epsilon(1e-15));
}

TEST_CASE("srgb: values far below 0 take the linear branch with finite values and gradients (no NaN from the "
          "power branch)",
          "[ops][shading][colour]") {
  for (auto f : {&shading::srgb_to_linear, &shading::linear_to_srgb}) {
    Tensor x = gr::testing::shading::leaf(values({-5.0, -0.06, -1e-3}));
    const Tensor y = f(x);
    backward(sum(y));
    CHECK(all_finite(y));
    CHECK(all_finite(x.grad()));
  }
  Tensor x = gr::testing::shading::leaf(values({-5.0}));
  backward(shading::srgb_to_linear(x));
  CHECK(x.grad().item() == Approx(1 / 12.92).epsilon(1e-15));
}

TEST_CASE("srgb: float32 works and keeps its dtype", "[ops][shading][colour]") {
  const Tensor x = Tensor::from_values({0.5, 0.01}, {2});
  const Tensor y = shading::srgb_to_linear(x);
  CHECK(y.dtype() == DType::Float32);
  CHECK(y.at({0}) == Approx(0.21404114048223255).epsilon(1e-6));
  CHECK(shading::linear_to_srgb(y).at({1}) == Approx(0.01).epsilon(1e-5));
}

TEST_CASE("srgb: an int32 or undefined argument is rejected naming 'x'", "[ops][shading][colour][errors]") {
  CHECK_THROWS_AS(shading::srgb_to_linear(Tensor::zeros({3}, DType::Int32)), DTypeError);
  CHECK_THROWS_WITH(shading::srgb_to_linear(Tensor::zeros({3}, DType::Int32)),
                    Catch::Contains("srgb_to_linear") && Catch::Contains("'x'"));
  CHECK_THROWS_WITH(shading::linear_to_srgb(Tensor()), Catch::Contains("linear_to_srgb") && Catch::Contains("'x'"));
}
