// Convex polygons in screen space for the exact reference: clipping by a
// half-plane, area, and subtraction of a convex region (given as the
// intersection of half-planes), all in plain double arithmetic.
#pragma once

#include <vector>

namespace gr::bench::exact {

struct Point {
  double x, y;
};

// f(x, y) = a x + b y + c; as a half-plane it keeps f >= 0.
struct Affine {
  double a, b, c;
  double operator()(Point p) const { return a * p.x + b * p.y + c; }
  Affine operator-(const Affine& o) const { return {a - o.a, b - o.b, c - o.c}; }
  Affine operator-() const { return {-a, -b, -c}; }
};

// A convex polygon, counter-clockwise in the sense of a positive signed_area.
using Polygon = std::vector<Point>;

// Pieces whose area (in pixels) is at most this are dropped, and an occluder
// that overlaps a piece by at most this leaves it whole: shared mesh edges
// then do not cut pieces into slivers. Each such decision changes an
// integral by at most 1e-15 of a pixel.
constexpr double kNegligibleArea = 1e-15;

// 1/2 sum (x_i y_{i+1} - x_{i+1} y_i): positive for the orientation used here.
double signed_area(const Polygon& p);

// out = the part of `in` where h >= 0 (Sutherland-Hodgman for one plane).
void clip(const Polygon& in, const Affine& h, Polygon& out);

// The half-planes whose intersection is the convex polygon p (p with a
// positive signed area), one per edge, each >= 0 inside.
std::vector<Affine> inward_edges(const Polygon& p);

// Appends to `out` convex pieces covering r minus the convex region
// {every h in region >= 0}: r is split along each region edge in turn, the
// outer part kept and the inner part carried on (at most region.size() pieces).
void subtract(const Polygon& r, const std::vector<Affine>& region, std::vector<Polygon>& out);

}  // namespace gr::bench::exact
