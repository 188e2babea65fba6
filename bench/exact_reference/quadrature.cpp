#include "bench/exact_reference/quadrature.h"

#include <cmath>

namespace gr::bench::exact {

GaussLegendre gauss_legendre(int n) {
  constexpr double kPi = 3.14159265358979323846;
  GaussLegendre rule;
  rule.nodes.resize(n);
  rule.weights.resize(n);
  for (int i = 0; i < n; ++i) {
    // Newton on P_n from the Chebyshev-like guess; P_n by the three-term recurrence.
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double pk = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = pk;
      }
      dp = n * (x * p1 - p0) / (x * x - 1);  // P_n'(x)
      const double step = p1 / dp;
      x -= step;
      if (std::abs(step) < 1e-16) break;
    }
    // On [-1, 1]: weight 2 / ((1 - x^2) P_n'(x)^2); mapped to [0, 1].
    rule.nodes[i] = 0.5 * (1 - x);
    rule.weights[i] = 1 / ((1 - x * x) * dp * dp);
  }
  return rule;
}

std::vector<TriangleNode> triangle_rule(int n) {
  // Duffy: (u, v) in [0, 1]^2 -> p0 + u (p1 - p0) + u v (p2 - p1), Jacobian
  // u * 2 area; so a node at (u, v) has s = u (1 - v), t = u v, weight 2 u w_u w_v.
  const GaussLegendre g = gauss_legendre(n);
  std::vector<TriangleNode> nodes;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double u = g.nodes[i], v = g.nodes[j];
      nodes.push_back({u * (1 - v), u * v, 2 * u * g.weights[i] * g.weights[j]});
    }
  return nodes;
}

}  // namespace gr::bench::exact
