#include <catch2/catch.hpp>

#include <cmath>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;

TEST_CASE("tape: backward accumulates into every use of a leaf", "[autodiff][tape]") {
  Tensor x = Tensor::from_values({1, 2, 3}, {3}, DType::Float64).set_requires_grad();
  Tensor loss = sum(x * x + x);  // dL/dx = 2x + 1
  backward(loss);
  CHECK(x.grad().to_vector() == std::vector<double>{3, 5, 7});
  // A second forward + backward adds to the existing gradient.
  backward(sum(x * 2.0));
  CHECK(x.grad().to_vector() == std::vector<double>{5, 7, 9});
  x.zero_grad();
  CHECK_FALSE(x.grad().defined());
}

TEST_CASE("tape: ops whose inputs need no gradient record nothing", "[autodiff][tape]") {
  Tape::current().clear();
  Tensor a = Tensor::ones({4});
  Tensor b = exp(a) * a + 1.0;
  CHECK(Tape::current().size() == 0);
  CHECK_FALSE(b.requires_grad());
  Tensor w = Tensor::ones({4}).set_requires_grad();
  Tensor c = b * w;  // only this op touches w
  CHECK(Tape::current().size() == 1);
  CHECK(c.requires_grad());
  Tape::current().clear();
}

TEST_CASE("tape: nothing is recorded under NoGradGuard", "[autodiff][tape]") {
  Tape::current().clear();
  Tensor w = Tensor::ones({4}).set_requires_grad();
  {
    NoGradGuard guard;
    Tensor y = w * w;
    CHECK_FALSE(y.requires_grad());
    CHECK(Tape::current().size() == 0);
  }
  CHECK(grad_mode_enabled());
}

TEST_CASE("tape: a second backward after the tape is freed throws", "[autodiff][tape][errors]") {
  Tensor w = Tensor::ones({3}).set_requires_grad();
  Tensor loss = sum(w * w);
  backward(loss);
  CHECK(Tape::current().size() == 0);  // swept completely: emptied for the next iteration
  CHECK_THROWS_AS(backward(loss), TapeError);
  CHECK_THROWS_WITH(backward(loss), Catch::Contains("freed"));
}

TEST_CASE("tape: tensors computed before a clear cannot feed a new recorded op", "[autodiff][tape][errors]") {
  Tensor w = Tensor::ones({3}).set_requires_grad();
  Tensor y = w * w;
  Tape::current().clear();
  CHECK_THROWS_AS(y * w, TapeError);
  Tensor z = y.detach() * w;  // a detached copy is a constant: fine
  CHECK(z.requires_grad());
  Tape::current().clear();
}

TEST_CASE("tape: backward on a non-scalar needs an upstream gradient of its shape", "[autodiff][tape][errors]") {
  Tensor w = Tensor::ones({3}).set_requires_grad();
  Tensor y = w * w;
  CHECK_THROWS_WITH(backward(y), Catch::Contains("one element"));
  CHECK_THROWS_AS(backward(y, Tensor::ones({2})), TapeError);
  backward(y, Tensor::from_values({1, 2, 3}, {3}));
  CHECK(w.grad().to_vector() == std::vector<double>{2, 4, 6});
}

TEST_CASE("tape: backward on a tensor that needs no gradient throws", "[autodiff][tape][errors]") {
  Tensor a = Tensor::ones({1});
  CHECK_THROWS_AS(backward(sum(a)), TapeError);
}

TEST_CASE("tape: saved values are released during the sweep", "[autodiff][tape]") {
  Tensor w = Tensor::ones({1000}, DType::Float64).set_requires_grad();
  std::weak_ptr<TensorImpl> intermediate;
  Tensor loss;
  {
    Tensor y = exp(w);  // exp saves its output for the adjoint
    intermediate = y.impl_ptr();
    loss = sum(y * y);
  }
  CHECK_FALSE(intermediate.expired());  // held by the tape
  backward(loss);
  CHECK(intermediate.expired());
}

TEST_CASE("tape: a repeated optimization step allocates no new storage after warm-up", "[autodiff][tape]") {
  Tensor w = Tensor::uniform({4096}, -1, 1, 3).set_requires_grad();
  Tensor target = Tensor::uniform({4096}, -1, 1, 4);
  auto step = [&] {
    Tensor loss = mean(pow(w - target, 2.0));
    backward(loss);
    float* pw = w.data<float>();
    const float* pg = w.grad().data<float>();
    for (std::int64_t i = 0; i < w.numel(); ++i) pw[i] -= 0.1f * pg[i];
    w.zero_grad();
  };
  step();
  step();
  const auto before = storage_stats().fresh_allocations;
  const auto tape_capacity = Tape::current().size();
  for (int i = 0; i < 5; ++i) step();
  CHECK(storage_stats().fresh_allocations == before);
  CHECK(Tape::current().size() == tape_capacity);
}

TEST_CASE("gradcheck: reports the worst element of a wrong gradient", "[autodiff][gradcheck]") {
  // An op with a deliberately wrong adjoint: y = x^2 with dL/dx = g x (should be 2 g x).
  auto wrong_square = [](const Tensor& x) {
    Tensor out = x.copy();
    double* d = out.data<double>();
    for (std::int64_t i = 0; i < out.numel(); ++i) d[i] *= d[i];
    if (should_record({x}))
      record("wrong_square", {x}, {&out}, [x](AdjointContext& ctx) {
        ctx.accumulate(0, ctx.grad_output() * x);
      });
    return out;
  };
  Tensor x = gr::testing::random_input({5}, 0.5, 1.5, 1);
  GradcheckResult r = gradcheck([&](const std::vector<Tensor>& in) { return wrong_square(in[0]); }, {x});
  CHECK_FALSE(r.passed);
  CHECK(r.worst_input == 0);
  CHECK(r.worst_index >= 0);
  CHECK(r.max_rel_error > 0.1);
  CHECK_THAT(r.report(), Catch::Contains("FAILED"));
}

TEST_CASE("gradcheck: refuses float32 inputs and inputs that need no gradient", "[autodiff][gradcheck][errors]") {
  auto f = [](const std::vector<Tensor>& in) { return in[0] * in[0]; };
  Tensor x32 = Tensor::ones({2}).set_requires_grad();
  CHECK_THROWS_AS(gradcheck(f, {x32}), DTypeError);
  Tensor x = Tensor::ones({2}, DType::Float64);
  CHECK_THROWS_AS(gradcheck(f, {x}), ValueError);
}

TEST_CASE("tape: an input whose values the adjoint does not need is not kept alive", "[autodiff][tape]") {
  // sum needs only its input's shape: once the caller drops the intermediate,
  // its buffer must be free although backward has not run yet.
  Tensor x = Tensor::uniform({1000}, -1, 1, 3, DType::Float64).set_requires_grad();
  Tensor mid = x * 2.0;
  std::weak_ptr<TensorImpl> mid_impl = mid.impl_ptr();
  Tensor loss = sum(mid);
  mid = Tensor();
  CHECK(mid_impl.expired());
  backward(loss);
  REQUIRE(x.grad().defined());
  for (double g : x.grad().to_vector()) CHECK(g == 2.0);
}

TEST_CASE("tape: a loop that logs a value computed after the loss keeps a flat tape", "[autodiff][tape]") {
  // psnr = -10 log10(loss) is recorded after the loss and never backpropagated;
  // backward(loss) frees its nodes too, so the tape does not grow.
  Tensor w = Tensor::uniform({64}, -1, 1, 3).set_requires_grad();
  const Tensor target = Tensor::uniform({64}, -1, 1, 4);
  std::size_t nodes_first = 0;
  std::int64_t fresh_after_warmup = 0;
  std::size_t grown = 0, not_emptied = 0;
  for (int i = 0; i < 10000; ++i) {
    Tensor loss = mean(pow(w - target, 2.0));
    Tensor psnr = -10.0 * log(loss) / std::log(10.0);
    if (i == 0) nodes_first = Tape::current().size();
    grown += Tape::current().size() != nodes_first;
    backward(loss);
    not_emptied += Tape::current().size() != 0;
    {
      NoGradGuard no_grad;
      float* pw = w.data<float>();
      const float* pg = w.grad().data<float>();
      for (std::int64_t k = 0; k < w.numel(); ++k) pw[k] -= 0.01f * pg[k];
    }
    w.zero_grad();
    if (i == 10) fresh_after_warmup = storage_stats().fresh_allocations;
  }
  CHECK(nodes_first > 0);
  CHECK(grown == 0);
  CHECK(not_emptied == 0);
  CHECK(storage_stats().fresh_allocations == fresh_after_warmup);
}

TEST_CASE("tape: a tensor recorded after the loss is unusable once backward(loss) ran", "[autodiff][tape][errors]") {
  Tensor w = Tensor::ones({3}).set_requires_grad();
  Tensor loss = sum(w * w);
  Tensor psnr = -10.0 * log(loss);
  backward(loss);
  CHECK(std::isfinite(psnr.item()));  // its value stays readable
  CHECK_THROWS_AS(backward(psnr), TapeError);
  CHECK_THROWS_WITH(psnr * w, Catch::Contains("freed by backward()"));
  Tensor ok = psnr.detach() * w;  // detached: a constant
  CHECK(ok.requires_grad());
  Tape::current().clear();
}
