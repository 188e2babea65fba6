// Adam's step runs every parameter's update in one parallel loop: the result
// is bit-identical for any thread count and to one optimizer per parameter.
#include <catch2/catch.hpp>

#include <vector>

#include "autodiff/optim.h"
#include "autodiff/base/parallel.h"
#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::same_bits;

namespace {

// Parameters of the fit's sizes and more: 2562 x 3 twice, one above a grain,
// a float64 one, an empty one and one that gets no gradient.
std::vector<Tensor> make_params() {
  return {Tensor::uniform({2562, 3}, -1, 1, 1).set_requires_grad(),
          Tensor::uniform({2562, 3}, 0, 1, 2).set_requires_grad(),
          Tensor::uniform({40000}, -1, 1, 3).set_requires_grad(),
          Tensor::uniform({7}, -1, 1, 4, DType::Float64).set_requires_grad(),
          Tensor::zeros({0, 3}).set_requires_grad(),
          Tensor::uniform({5}, -1, 1, 5).set_requires_grad()};
}

// A loss that reaches every parameter but the last, with different curvature each.
Tensor loss_of(const std::vector<Tensor>& p) {
  return sum(pow(p[0], 3.0)) + sum(sin(p[1])) + sum(p[2] * p[2]) + cast(sum(exp(p[3])), DType::Float32) + sum(p[4]);
}

const AdamOptions kFirst{0.03, 0.8, 0.99, 1e-6}, kSecond{0.002};

// Five steps of one Adam with two groups on `threads` threads.
std::vector<Tensor> steps_grouped(int threads) {
  set_num_threads(threads);
  std::vector<Tensor> p = make_params();
  Adam adam({{{p[0], p[2], p[4]}, kFirst}, {{p[1], p[3], p[5]}, kSecond}});
  for (int step = 0; step < 5; ++step) {
    adam.set_lr(0, kFirst.lr / (step + 1));
    backward(loss_of(p));
    adam.step();
    adam.zero_grad();
  }
  set_num_threads(0);
  return p;
}

}  // namespace

TEST_CASE("Adam: five steps over parameters of every size are bit-identical for 1, 2 and 8 threads and to one "
          "optimizer per parameter",
          "[autodiff][optim][determinism]") {
  const std::vector<Tensor> one = steps_grouped(1);
  for (int threads : {2, 8}) {
    const std::vector<Tensor> many = steps_grouped(threads);
    for (std::size_t k = 0; k < one.size(); ++k) {
      INFO(threads << " threads, parameter " << k);
      CHECK(same_bits(one[k], many[k]));
    }
  }
  // One optimizer per parameter (the per-parameter loops step() ran before).
  set_num_threads(1);
  std::vector<Tensor> p = make_params();
  std::vector<Adam> separate;
  for (std::size_t k = 0; k < p.size(); ++k) separate.emplace_back(std::vector<Tensor>{p[k]}, k % 2 ? kSecond : kFirst);
  for (int step = 0; step < 5; ++step) {
    for (std::size_t k = 0; k < p.size(); k += 2) separate[k].set_lr(kFirst.lr / (step + 1));
    backward(loss_of(p));
    for (Adam& a : separate) a.step(), a.zero_grad();
  }
  set_num_threads(0);
  for (std::size_t k = 0; k < p.size(); ++k) {
    INFO("parameter " << k);
    CHECK(same_bits(one[k], p[k]));
  }
  // The parameter without a gradient did not move.
  CHECK(same_bits(one[5], Tensor::uniform({5}, -1, 1, 5)));
}
