#include "autodiff/optim.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "autodiff/parallel.h"

namespace gr {
namespace {

void check_options(const AdamOptions& o, const std::string& where) {
  if (!(o.lr > 0) || !(o.beta1 >= 0 && o.beta1 < 1) || !(o.beta2 >= 0 && o.beta2 < 1) || !(o.eps > 0))
    throw ValueError("Adam: " + where + " needs lr > 0, 0 <= beta1, beta2 < 1 and eps > 0");
}

void check_lr(double lr, const std::string& where) {
  if (!(lr > 0) || !std::isfinite(lr)) throw ValueError("Adam: " + where + " learning rate must be finite and > 0");
}

}  // namespace

Adam::Adam(std::vector<Tensor> params, AdamOptions options)
    : Adam(std::vector<AdamGroup>{{std::move(params), options}}) {}

Adam::Adam(std::vector<AdamGroup> groups) {
  std::vector<const TensorImpl*> seen;
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const std::string name = "group " + std::to_string(gi);
    check_options(groups[gi].options, name);
    Group group{{}, groups[gi].options};
    for (std::size_t i = 0; i < groups[gi].params.size(); ++i) {
      const Tensor& p = groups[gi].params[i];
      const std::string param = name + " parameter " + std::to_string(i);
      if (!p.defined() || !p.is_leaf() || !p.requires_grad())
        throw ValueError("Adam: " + param + " must be a leaf tensor that requires grad");
      if (std::find(seen.begin(), seen.end(), p.impl()) != seen.end())
        throw ValueError("Adam: " + param + " was given before (each parameter may appear once)");
      seen.push_back(p.impl());
      group.slots.push_back({p, Tensor::zeros(p.shape(), DType::Float64), Tensor::zeros(p.shape(), DType::Float64)});
    }
    groups_.push_back(std::move(group));
  }
}

const AdamOptions& Adam::options(std::size_t group) const {
  if (group >= groups_.size())
    throw IndexError("Adam: group " + std::to_string(group) + " does not exist (" + std::to_string(groups_.size()) +
                     " groups)");
  return groups_[group].options;
}

void Adam::set_lr(std::size_t group, double lr) {
  options(group);  // range check
  check_lr(lr, "group " + std::to_string(group));
  groups_[group].options.lr = lr;
}

void Adam::set_lr(double lr) {
  check_lr(lr, "every group's");
  for (Group& g : groups_) g.options.lr = lr;
}

void Adam::step() {
  ++t_;
  for (Group& group : groups_) {
    const double b1 = group.options.beta1, b2 = group.options.beta2;
    const double c1 = 1 - std::pow(b1, double(t_)), c2 = 1 - std::pow(b2, double(t_));
    const double lr = group.options.lr, eps = group.options.eps;
    for (Slot& s : group.slots) {
      Tensor g = s.param.grad();
      if (!g.defined()) continue;
      double* m = s.m.data<double>();
      double* v = s.v.data<double>();
      dispatch_float(s.param.dtype(), "Adam", [&](auto tag) {
        using T = decltype(tag);
        T* x = s.param.data<T>();
        const T* gp = g.data<T>();
        parallel_for(0, s.param.numel(), kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
          for (std::int64_t k = lo; k < hi; ++k) {
            const double gk = gp[k];
            m[k] = b1 * m[k] + (1 - b1) * gk;
            v[k] = b2 * v[k] + (1 - b2) * gk * gk;
            x[k] = T(x[k] - lr * (m[k] / c1) / (std::sqrt(v[k] / c2) + eps));
          }
        });
      });
    }
  }
}

void Adam::zero_grad() {
  for (Group& g : groups_)
    for (Slot& s : g.slots) s.param.zero_grad();
}

}  // namespace gr
