// Finite-difference directional derivatives of a float64 loss of the time_error scene.
#include "bench/time_error_reference.h"

#include <chrono>
#include <cmath>
#include <random>

#include "autodiff/tape.h"
#include "ops/ops.h"

namespace gr::bench {
namespace {

Tensor normal_tensor(std::int64_t rows, std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  std::vector<double> v(static_cast<std::size_t>(3 * rows));
  for (double& x : v) x = normal(rng);
  return Tensor::from_values(v, {rows, 3}, DType::Float64);
}

}  // namespace

Directions random_directions(const Tensor& points, int num_position, int num_colour, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> phase(0, 2 * 3.14159265358979323846);
  const std::int64_t n = points.size(0);
  const double* p = points.data<double>();
  Directions d;
  for (int k = 0; k < num_position; ++k) {
    // v_c(p) = sum_m a_m sin(w_m . p + phi_m) per coordinate c, |w_m| ~ 2.
    std::vector<double> v(static_cast<std::size_t>(3 * n), 0.0);
    for (int c = 0; c < 3; ++c)
      for (int m = 0; m < 6; ++m) {
        const double a = normal(rng), wx = 2 * normal(rng) / std::sqrt(3.0), wy = 2 * normal(rng) / std::sqrt(3.0),
                     wz = 2 * normal(rng) / std::sqrt(3.0), phi = phase(rng);
        for (std::int64_t i = 0; i < n; ++i)
          v[3 * i + c] += a * std::sin(wx * p[3 * i] + wy * p[3 * i + 1] + wz * p[3 * i + 2] + phi);
      }
    double ss = 0;
    for (double x : v) ss += x * x;
    const double scale = 1 / std::sqrt(ss / double(v.size()));
    for (double& x : v) x *= scale;
    d.position.push_back(Tensor::from_values(v, {n, 3}, DType::Float64));
  }
  for (int k = 0; k < num_colour; ++k) d.colour.push_back(normal_tensor(n, rng));
  return d;
}

SceneLoss rendered_loss(const TimeErrorScene& scene, const Tensor& target, const RenderSettings& settings) {
  return [&scene, target, settings](const Tensor& points, const Tensor& colours) {
    NoGradGuard no_grad;
    return scene.loss(points, colours, target, settings).item();
  };
}

ReferenceDerivatives finite_difference_reference(const TimeErrorScene& scene, const SceneLoss& loss,
                                                 const Directions& directions, const FiniteDifferenceSteps& steps) {
  NoGradGuard no_grad;
  const auto start = std::chrono::steady_clock::now();
  const Tensor& x = scene.points();
  const Tensor& c = scene.colours();
  ReferenceDerivatives r;
  // A direction moves each vertex by about |v_i| h ~ sqrt(3) h in 3-D; in the
  // image by about sqrt(2) h times pixels_per_unit (depth motion barely shows).
  const double h = steps.position_px / (std::sqrt(2.0) * scene.pixels_per_unit());
  for (const Tensor& v : directions.position) {
    const double l1 = loss(x + h * v, c), lm1 = loss(x - h * v, c);
    const double l2 = loss(x + 2 * h * v, c), lm2 = loss(x - 2 * h * v, c);
    r.position.push_back((8 * (l1 - lm1) - (l2 - lm2)) / (12 * h));
    r.position_h.push_back((l1 - lm1) / (2 * h));
    r.position_2h.push_back((l2 - lm2) / (4 * h));
  }
  const double hc = steps.colour;
  for (const Tensor& v : directions.colour)
    r.colour.push_back((loss(x, c + hc * v) - loss(x, c - hc * v)) / (2 * hc));
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

std::vector<double> project(const Tensor& grad, const std::vector<Tensor>& directions) {
  const std::vector<double> g = grad.to_vector();
  std::vector<double> out;
  for (const Tensor& v : directions) {
    const double* d = v.data<double>();
    double s = 0;
    for (std::size_t i = 0; i < g.size(); ++i) s += g[i] * d[i];
    out.push_back(s);
  }
  return out;
}

double relative_l2(const std::vector<double>& a, const std::vector<double>& r) {
  double num = 0, den = 0;
  for (std::size_t k = 0; k < r.size(); ++k) num += (a[k] - r[k]) * (a[k] - r[k]), den += r[k] * r[k];
  return std::sqrt(num / den);
}

}  // namespace gr::bench
