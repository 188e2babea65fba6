// The Blinn-Phong shading graph used by the benchmarks (issue 2, item 7),
// written with the tensor API exactly as a user would:
//   l = normalize(light - p), v = normalize(cam - p), h = normalize(l + v)
//   colour = albedo * max(n.l, 0) + 0.5 * max(n.h, 0)^32
//   loss = mean((colour - target)^2)
#pragma once

#include "ops/ops.h"

namespace gr::bench {

struct ShadingScene {
  Tensor p, n, albedo, light, cam, target;  // p, n, albedo, target: [N, 3]; light, cam: [3]
};

inline ShadingScene make_shading_scene(std::int64_t pixels, DType dtype) {
  ShadingScene s;
  s.p = Tensor::uniform({pixels, 3}, -1, 1, 1, dtype);
  {
    NoGradGuard no_grad;
    s.n = normalize(Tensor::uniform({pixels, 3}, -1, 1, 2, dtype));
  }
  s.albedo = Tensor::uniform({pixels, 3}, 0, 1, 3, dtype);
  s.light = Tensor::from_values({2, 3, 4}, {3}, dtype);
  s.cam = Tensor::from_values({0, 0, 5}, {3}, dtype);
  s.target = Tensor::uniform({pixels, 3}, 0, 1, 4, dtype);
  // Parameters an inverse-rendering fit would optimize.
  s.n.set_requires_grad();
  s.albedo.set_requires_grad();
  s.light.set_requires_grad();
  return s;
}

inline Tensor blinn_phong_loss(const ShadingScene& s) {
  Tensor l = normalize(s.light - s.p);
  Tensor v = normalize(s.cam - s.p);
  Tensor h = normalize(l + v);
  Tensor diffuse = s.albedo * maximum(dot(s.n, l), 0.0);
  Tensor spec = pow(maximum(dot(s.n, h), 0.0), 32.0);
  Tensor colour = diffuse + 0.5 * spec;
  return mean(pow(colour - s.target, 2.0));
}

// The loss's per-pixel part, row-wise for map_rows / map_rows_mean: rows
// {p, n, albedo, target}, shared {light, cam}; mean of it = blinn_phong_loss.
inline Tensor blinn_phong_squared_error(const std::vector<Tensor>& r, const std::vector<Tensor>& s) {
  Tensor l = normalize(s[0] - r[0]);
  Tensor v = normalize(s[1] - r[0]);
  Tensor h = normalize(l + v);
  Tensor colour = r[2] * maximum(dot(r[1], l), 0.0) + 0.5 * pow(maximum(dot(r[1], h), 0.0), 32.0);
  return pow(colour - r[3], 2.0);
}

}  // namespace gr::bench
