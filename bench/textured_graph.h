// A texture-heavy shading graph for the fused-baseline comparison (issue 17),
// written with the tensor API as a user would:
//   colour = texture(tex, uv) * shade      (bilinear, repeat)
//   loss   = mean((colour - target)^2)
// with a smooth uv map (an unwrapped surface seen at about 2 pixels per texel).
#pragma once

#include <cmath>
#include <vector>

#include "ops/ops.h"

namespace gr::bench {

struct TexturedScene {
  Tensor tex;                   // [Ht, Wt, 3], requires grad
  Tensor uv;                    // [N, 2], requires grad
  Tensor shade, target;         // [N, 1], [N, 3]
};

inline TexturedScene make_textured_scene(int width, int height, int tex_side, DType dtype) {
  TexturedScene s;
  const std::int64_t n = std::int64_t(width) * height;
  s.tex = Tensor::uniform({tex_side, tex_side, 3}, 0, 1, 5, dtype);
  std::vector<double> uv(2 * n);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double a = double(x) / width, b = double(y) / height;
      uv[2 * (std::int64_t(y) * width + x)] = 0.05 + 0.9 * a + 0.02 * std::sin(6.0 * b);
      uv[2 * (std::int64_t(y) * width + x) + 1] = 0.95 - 0.9 * b + 0.02 * std::sin(5.0 * a);
    }
  s.uv = Tensor::from_values(uv, {n, 2}, dtype);
  s.shade = Tensor::uniform({n, 1}, 0.3, 1, 6, dtype);
  s.target = Tensor::uniform({n, 3}, 0, 1, 7, dtype);
  s.tex.set_requires_grad();
  s.uv.set_requires_grad();
  return s;
}

inline Tensor textured_loss(const TexturedScene& s) {
  return mean(pow(texture(s.tex, s.uv) * s.shade - s.target, 2.0));
}

}  // namespace gr::bench
