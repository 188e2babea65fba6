// Adam, the optimizer every example uses (Kingma & Ba 2015):
//   m = b1 m + (1 - b1) g,   v = b2 v + (1 - b2) g^2
//   x -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps)
// Parameters are leaf tensors that require grad; step() reads their .grad()
// (a parameter without a gradient is left unchanged), updates them in place,
// and zero_grad() clears the gradients for the next iteration.
#pragma once

#include <vector>

#include "autodiff/tensor.h"

namespace gr {

struct AdamOptions {
  double lr = 1e-2;
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-8;
};

class Adam {
 public:
  explicit Adam(std::vector<Tensor> params, AdamOptions options = {});

  void step();
  void zero_grad();
  // Learning rate of parameter group i (all parameters share one by default).
  void set_lr(double lr) { options_.lr = lr; }
  double lr() const { return options_.lr; }
  long long steps() const { return t_; }

 private:
  std::vector<Tensor> params_;
  std::vector<Tensor> m_, v_;  // float64 moments, one pair per parameter
  AdamOptions options_;
  long long t_ = 0;
};

}  // namespace gr
