// The Blinn-Phong shading graph of bench/shading_graph.h written with
// libtorch's C++ API, on a copy of the same input values:
//   l = normalize(light - p), v = normalize(cam - p), h = normalize(l + v)
//   colour = albedo * max(n.l, 0) + 0.5 * max(n.h, 0)^32
//   loss = mean((colour - target)^2)
// normalize(x) = x / max(|x|, eps) with gradraster's eps (ops/tensor/vector.h), the
// same formula as torch::nn::functional::normalize.
#pragma once

#include <torch/torch.h>

#include <cstring>

#include "shading_graph.h"

namespace gr::bench {

struct TorchShadingScene {
  torch::Tensor p, n, albedo, light, cam, target;
};

// A torch tensor holding a copy of gradraster tensor `t`'s float32 values.
inline torch::Tensor torch_copy_of(const Tensor& t) {
  std::vector<std::int64_t> sizes = t.shape().dims();
  torch::Tensor out = torch::empty(sizes, torch::kFloat32);
  std::memcpy(out.data_ptr<float>(), t.data<float>(), sizeof(float) * static_cast<std::size_t>(t.numel()));
  return out;
}

// Same values as `s`; gradients on n, albedo and light, as in make_shading_scene.
inline TorchShadingScene torch_copy_of(const ShadingScene& s) {
  TorchShadingScene t{torch_copy_of(s.p),     torch_copy_of(s.n),   torch_copy_of(s.albedo),
                      torch_copy_of(s.light), torch_copy_of(s.cam), torch_copy_of(s.target)};
  t.n.set_requires_grad(true);
  t.albedo.set_requires_grad(true);
  t.light.set_requires_grad(true);
  return t;
}

inline torch::Tensor torch_normalize(const torch::Tensor& x) {
  return x / x.norm(2, {-1}, /*keepdim=*/true).clamp_min(kNormalizeEps);
}

inline torch::Tensor torch_dot(const torch::Tensor& a, const torch::Tensor& b) {
  return (a * b).sum(-1, /*keepdim=*/true);
}

inline torch::Tensor torch_blinn_phong_loss(const TorchShadingScene& s) {
  torch::Tensor l = torch_normalize(s.light - s.p);
  torch::Tensor v = torch_normalize(s.cam - s.p);
  torch::Tensor h = torch_normalize(l + v);
  torch::Tensor diffuse = s.albedo * torch_dot(s.n, l).clamp_min(0.0);
  torch::Tensor spec = torch_dot(s.n, h).clamp_min(0.0).pow(32.0);
  torch::Tensor colour = diffuse + 0.5 * spec;
  return (colour - s.target).pow(2.0).mean();
}

}  // namespace gr::bench
