// Helpers shared by the tests of ops/shading/: float64 vectors, random unit
// directions and the bit comparison of two runs.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "ops/ops.h"
#include "test_support.h"

namespace gr::testing::shading {

constexpr double kPi = 3.14159265358979323846;

inline Tensor vec(const std::vector<double>& v) {
  return Tensor::from_values(v, {static_cast<std::int64_t>(v.size())}, DType::Float64);
}
inline Tensor vec3(double x, double y, double z) { return vec({x, y, z}); }

// A float64 leaf requiring grad with t's values.
inline Tensor leaf(const Tensor& t) { return cast(t, DType::Float64).detach().copy().set_requires_grad(); }

// n random unit directions [n, 3], float64, no grad: uniform samples of the
// cube kept inside the shell 0.1 <= r <= 1 (so isotropic), normalized.
inline Tensor unit_directions(std::int64_t n, std::uint64_t seed) {
  const std::int64_t draws = 4 * n + 32;  // about half land in the shell
  const Tensor raw = Tensor::uniform({draws, 3}, -1, 1, seed, DType::Float64);
  std::vector<double> out;
  for (std::int64_t i = 0; i < draws && static_cast<std::int64_t>(out.size()) < 3 * n; ++i) {
    const double x = raw.at({i, 0}), y = raw.at({i, 1}), z = raw.at({i, 2});
    const double r = std::sqrt(x * x + y * y + z * z);
    if (r < 0.1 || r > 1) continue;
    out.insert(out.end(), {x / r, y / r, z / r});
  }
  REQUIRE(static_cast<std::int64_t>(out.size()) == 3 * n);
  return Tensor::from_values(out, {n, 3}, DType::Float64);
}

// Unit vectors in the plane of unit a and b (rows, broadcasting) at cosine
// `cos_angle` ([..., 1] or a number) from a; b must not be parallel to a. No grad.
inline Tensor at_angle(const Tensor& a, const Tensor& b, const Tensor& cos_angle) {
  NoGradGuard no_grad;
  const Tensor side = normalize(b - a * dot(a, b));
  return (a * cos_angle + side * sqrt(1.0 - cos_angle * cos_angle)).copy();
}
inline Tensor at_angle(const Tensor& a, const Tensor& b, double cos_angle) {
  return at_angle(a, b, Tensor::scalar(cos_angle, DType::Float64));
}

// n unit directions spread evenly over the sphere (Fibonacci lattice), [n, 3] float64.
inline Tensor sphere_directions(int n) {
  std::vector<double> d;
  for (int i = 0; i < n; ++i) {
    const double y = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - y * y), phi = i * kPi * (3 - std::sqrt(5.0));
    d.insert(d.end(), {r * std::cos(phi), y, r * std::sin(phi)});
  }
  return Tensor::from_values(d, {n, 3}, DType::Float64);
}

}  // namespace gr::testing::shading
