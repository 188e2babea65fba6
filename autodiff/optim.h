// Adam, the optimizer every example uses (Kingma & Ba 2015):
//   m = b1 m + (1 - b1) g,   v = b2 v + (1 - b2) g^2
//   x -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps)
// Parameters are leaf tensors that require grad, in groups that each have
// their own options (learning rate, betas, eps); the step count t is shared.
// step() reads each parameter's .grad() (a parameter without a gradient is
// left unchanged, its moments too), updates it in place, and zero_grad()
// clears the gradients for the next iteration.
//
//   Adam adam({{{positions}, AdamOptions{0.02}}, {{colours}, AdamOptions{0.03}}});
//   adam.set_lr(1, 0.01);  // the colours' group only
#pragma once

#include <cstddef>
#include <vector>

#include "autodiff/base/tensor.h"

namespace gr {

struct AdamOptions {
  double lr = 1e-2;
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-8;
};

// Parameters that share one set of options.
struct AdamGroup {
  std::vector<Tensor> params;
  AdamOptions options;
};

class Adam {
 public:
  // One group holding every parameter.
  explicit Adam(std::vector<Tensor> params, AdamOptions options = {});
  // A parameter may belong to one group only (ValueError otherwise).
  explicit Adam(std::vector<AdamGroup> groups);

  void step();
  void zero_grad();

  std::size_t num_groups() const { return groups_.size(); }
  // Options of group `group` (IndexError if there is no such group).
  const AdamOptions& options(std::size_t group = 0) const;
  double lr(std::size_t group = 0) const { return options(group).lr; }
  // Learning rate of one group, or of every group.
  void set_lr(std::size_t group, double lr);
  void set_lr(double lr);
  long long steps() const { return t_; }

 private:
  struct Slot {
    Tensor param;
    Tensor m, v;  // float64 moments
  };
  struct Group {
    std::vector<Slot> slots;
    AdamOptions options;
  };
  std::vector<Group> groups_;
  long long t_ = 0;
};

}  // namespace gr
