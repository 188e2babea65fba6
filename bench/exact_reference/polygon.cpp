#include "bench/exact_reference/polygon.h"

#include <cstddef>

namespace gr::bench::exact {

double signed_area(const Polygon& p) {
  double twice = 0;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) {
    const Point& a = p[i];
    const Point& b = p[(i + 1) % n];
    twice += a.x * b.y - b.x * a.y;
  }
  return 0.5 * twice;
}

void clip(const Polygon& in, const Affine& h, Polygon& out) {
  out.clear();
  const std::size_t n = in.size();
  if (n == 0) return;
  Point prev = in[n - 1];
  double fprev = h(prev);
  for (std::size_t i = 0; i < n; ++i) {
    const Point cur = in[i];
    const double fcur = h(cur);
    if ((fprev >= 0) != (fcur >= 0)) {
      // The crossing point, from the two endpoint values (the same for both
      // sides of a split, so the pieces meet exactly).
      const double t = fprev / (fprev - fcur);
      out.push_back({prev.x + t * (cur.x - prev.x), prev.y + t * (cur.y - prev.y)});
    }
    if (fcur >= 0) out.push_back(cur);
    prev = cur;
    fprev = fcur;
  }
  if (out.size() < 3) out.clear();
}

std::vector<Affine> inward_edges(const Polygon& p) {
  std::vector<Affine> edges;
  for (std::size_t i = 0, n = p.size(); i < n; ++i) {
    const Point& a = p[i];
    const Point& b = p[(i + 1) % n];
    // cross(b - a, q - a) >= 0: q on the inner (left) side of a -> b.
    const double ea = -(b.y - a.y), eb = b.x - a.x;
    edges.push_back({ea, eb, -(ea * a.x + eb * a.y)});
  }
  return edges;
}

void subtract(const Polygon& r, const std::vector<Affine>& region, std::vector<Polygon>& out) {
  Polygon inside = r, scratch;
  for (const Affine& h : region) {
    clip(inside, h, scratch);
    inside.swap(scratch);
    if (inside.empty()) break;
  }
  if (inside.empty() || signed_area(inside) <= kNegligibleArea) {
    out.push_back(r);
    return;
  }
  Polygon rest = r, piece;
  for (const Affine& h : region) {
    clip(rest, -h, piece);
    if (!piece.empty() && signed_area(piece) > kNegligibleArea) out.push_back(piece);
    clip(rest, h, scratch);
    rest.swap(scratch);
    if (rest.empty()) break;
  }
}

}  // namespace gr::bench::exact
