#include "autodiff/optim.h"

#include <cmath>

#include "autodiff/parallel.h"

namespace gr {

Adam::Adam(std::vector<Tensor> params, AdamOptions options) : params_(std::move(params)), options_(options) {
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const Tensor& p = params_[i];
    if (!p.defined() || !p.is_leaf() || !p.requires_grad())
      throw ValueError("Adam: parameter " + std::to_string(i) + " must be a leaf tensor that requires grad");
    m_.push_back(Tensor::zeros(p.shape(), DType::Float64));
    v_.push_back(Tensor::zeros(p.shape(), DType::Float64));
  }
  if (!(options.lr > 0) || !(options.beta1 >= 0 && options.beta1 < 1) || !(options.beta2 >= 0 && options.beta2 < 1) ||
      !(options.eps > 0))
    throw ValueError("Adam: need lr > 0, 0 <= beta1, beta2 < 1 and eps > 0");
}

void Adam::step() {
  ++t_;
  const double b1 = options_.beta1, b2 = options_.beta2;
  const double c1 = 1 - std::pow(b1, double(t_)), c2 = 1 - std::pow(b2, double(t_));
  const double lr = options_.lr, eps = options_.eps;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    Tensor g = params_[i].grad();
    if (!g.defined()) continue;
    double* m = m_[i].data<double>();
    double* v = v_[i].data<double>();
    dispatch_float(params_[i].dtype(), "Adam", [&](auto tag) {
      using T = decltype(tag);
      T* x = params_[i].data<T>();
      const T* gp = g.data<T>();
      parallel_for(0, params_[i].numel(), kElementwiseGrain, [&](std::int64_t lo, std::int64_t hi) {
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

void Adam::zero_grad() {
  for (Tensor& p : params_) p.zero_grad();
}

}  // namespace gr
