// Quadrature on a triangle for the exact reference: the collapsed
// (Duffy) Gauss-Legendre product rule, n x n points, exact for polynomials of
// degree 2n - 2 and converging geometrically for the smooth rational
// perspective-correct attributes.
#pragma once

#include <vector>

namespace gr::bench::exact {

// Gauss-Legendre nodes and weights on [0, 1] (weights sum to 1), n >= 1.
struct GaussLegendre {
  std::vector<double> nodes, weights;
};
GaussLegendre gauss_legendre(int n);

// Nodes of a triangle (p0, p1, p2) as p0 + s (p1 - p0) + t (p2 - p0), with
// weights summing to 1: integral over the triangle ~ area * sum w f(node).
struct TriangleNode {
  double s, t, weight;
};
std::vector<TriangleNode> triangle_rule(int n);

}  // namespace gr::bench::exact
