#include "autodiff/optim.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "autodiff/base/parallel.h"

namespace gr {
namespace {

void check_options(const AdamOptions& o, const std::string& where) {
  if (!(o.lr > 0) || !(o.beta1 >= 0 && o.beta1 < 1) || !(o.beta2 >= 0 && o.beta2 < 1) || !(o.eps > 0))
    throw ValueError("Adam: " + where + " needs lr > 0, 0 <= beta1, beta2 < 1 and eps > 0");
}

void check_lr(double lr, const std::string& where) {
  if (!(lr > 0) || !std::isfinite(lr)) throw ValueError("Adam: " + where + " learning rate must be finite and > 0");
}

// Elements per parallel chunk: an update costs a square root and two
// divisions in double, several times a cheap elementwise op.
constexpr std::int64_t kAdamGrain = kElementwiseGrain / 8;

// One parameter's part of a step: its values x, gradient g and moments m, v,
// its group's constants, and where it starts in the step's joint index space.
struct Update {
  DType dtype;
  void* x;
  const void* g;
  double *m, *v;
  double b1, b2, c1, c2, lr, eps;
  std::int64_t begin, n;
};

// Elements [k0, k1) of one parameter (c1 = 1 - b1^t, c2 = 1 - b2^t):
//   m = b1 m + (1 - b1) g,  v = b2 v + (1 - b2) g^2,  x -= lr (m / c1) / (sqrt(v / c2) + eps).
template <class T>
void adam_update(const Update& u, std::int64_t k0, std::int64_t k1) {
  T* x = static_cast<T*>(u.x);
  const T* gp = static_cast<const T*>(u.g);
  double* m = u.m;
  double* v = u.v;
  const double b1 = u.b1, b2 = u.b2, c1 = u.c1, c2 = u.c2, lr = u.lr, eps = u.eps;
  for (std::int64_t k = k0; k < k1; ++k) {
    const double gk = gp[k];
    m[k] = b1 * m[k] + (1 - b1) * gk;
    v[k] = b2 * v[k] + (1 - b2) * gk * gk;
    x[k] = T(x[k] - lr * (m[k] / c1) / (std::sqrt(v[k] / c2) + eps));
  }
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
  // Every parameter's update, placed one after another in one index space, so
  // one parallel loop covers them all (the fit's parameters are a few
  // thousand values each: one loop per parameter would run each inline).
  std::vector<Update> updates;
  std::int64_t total = 0;
  for (Group& group : groups_) {
    const double b1 = group.options.beta1, b2 = group.options.beta2;
    const double c1 = 1 - std::pow(b1, double(t_)), c2 = 1 - std::pow(b2, double(t_));
    for (Slot& s : group.slots) {
      const Tensor g = s.param.grad();
      if (!g.defined()) continue;
      Update u{s.param.dtype(), nullptr, nullptr, s.m.data<double>(), s.v.data<double>(),
               b1, b2, c1, c2, group.options.lr, group.options.eps, total, s.param.numel()};
      dispatch_float(u.dtype, "Adam", [&](auto tag) {
        using T = decltype(tag);
        u.x = s.param.data<T>();
        u.g = g.data<T>();
      });
      updates.push_back(u);
      total += u.n;
    }
  }
  parallel_for(0, total, kAdamGrain, [&](std::int64_t lo, std::int64_t hi) {
    // The last update starting at or before lo, then those that start before hi.
    auto u = std::upper_bound(updates.begin(), updates.end(), lo,
                              [](std::int64_t k, const Update& x) { return k < x.begin; }) - 1;
    for (; u != updates.end() && u->begin < hi; ++u) {
      const std::int64_t k0 = std::max(lo, u->begin) - u->begin, k1 = std::min(hi, u->begin + u->n) - u->begin;
      if (u->dtype == DType::Float32)
        adam_update<float>(*u, k0, k1);
      else
        adam_update<double>(*u, k0, k1);
    }
  });
}

void Adam::zero_grad() {
  for (Group& g : groups_)
    for (Slot& s : g.slots) s.param.zero_grad();
}

}  // namespace gr
