// Cube-map face selection, projection derivatives and edge folding. The fold
// works on exact integers: a texel centre of face f is the 3D point
// (S ma_f + (2 col + 1 - S) e_s + (2 row + 1 - S) e_t) / S on the cube of
// half-side 1, so every coordinate below is that point scaled by S.
#include "raster/cube_map.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace gr::raster {

CubeProjection cube_project(double x, double y, double z) {
  CubeProjection p;
  const double d[3] = {x, y, z};
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return p;
  // Major axis: z if strictly the largest, else y if larger than x, else x.
  const double ax = std::abs(x), ay = std::abs(y), az = std::abs(z);
  const int m = az > std::max(ax, ay) ? 2 : ay > ax ? 1 : 0;
  if (d[m] == 0.0) return p;  // the zero vector
  p.face = 2 * m + (d[m] < 0.0 ? 1 : 0);
  const CubeFace& f = kCubeFaces[p.face];
  p.q = std::abs(d[m]);
  p.sc = f.s_sign * d[f.s_axis];
  p.tc = f.t_sign * d[f.t_axis];
  // s = (sc / |ma| + 1) / 2, t likewise; |sc| <= |ma|, so only rounding can leave [0, 1].
  p.s = std::min(1.0, std::max(0.0, 0.5 * p.sc / p.q + 0.5));
  p.t = std::min(1.0, std::max(0.0, 0.5 * p.tc / p.q + 0.5));
  // Quotient rule: ds = (dsc q - sc dq) / (2 q^2), dq = major_sign d(ma).
  const double h = 0.5 / p.q, h2 = h / p.q;
  p.ds[f.s_axis] = f.s_sign * h;
  p.ds[f.major] = -f.major_sign * p.sc * h2;
  p.dt[f.t_axis] = f.t_sign * h;
  p.dt[f.major] = -f.major_sign * p.tc * h2;
  return p;
}

void cube_project_hessian_times(const CubeProjection& p, const double v[3], double hs_v[3], double ht_v[3]) {
  for (int k = 0; k < 3; ++k) hs_v[k] = ht_v[k] = 0.0;
  if (p.face < 0) return;
  const CubeFace& f = kCubeFaces[p.face];
  const int m = f.major;
  const double q2 = p.q * p.q, q3 = q2 * p.q;
  // d^2 s / d dir^2: [s_axis][m] = [m][s_axis] = -s_sign major_sign / (2 q^2), [m][m] = sc / q^3.
  const double cs = -f.s_sign * f.major_sign * 0.5 / q2, ct = -f.t_sign * f.major_sign * 0.5 / q2;
  hs_v[f.s_axis] = cs * v[m];
  hs_v[m] = cs * v[f.s_axis] + p.sc / q3 * v[m];
  ht_v[f.t_axis] = ct * v[m];
  ht_v[m] = ct * v[f.t_axis] + p.tc / q3 * v[m];
}

CubeTexel cube_texel(int face, int col, int row, int size) {
  const bool off_col = col < 0 || col >= size, off_row = row < 0 || row >= size;
  if (!off_col && !off_row) return {face, col, row};
  if (off_col && off_row) return {};  // cube corner: only 3 texels meet there
  // The texel centre's point (times S) in the plane of `face`, beyond its edge.
  const CubeFace& f = kCubeFaces[face];
  const long long S = size;
  long long P[3];
  P[f.major] = f.major_sign * S;
  P[f.s_axis] = f.s_sign * (2LL * col + 1 - S);
  P[f.t_axis] = f.t_sign * (2LL * row + 1 - S);
  // Fold the overhang over the edge: the off axis stops at +-S (it becomes the
  // neighbour's major axis) and the old major axis shrinks by the overhang.
  const int off = off_col ? f.s_axis : f.t_axis;
  const long long overhang = std::llabs(P[off]) - S;
  P[off] = P[off] < 0 ? -S : S;
  P[f.major] = f.major_sign * (S - overhang);
  // Project onto the neighbour: column = (sc + S - 1) / 2 for sc = 2 col + 1 - S.
  const int nf = 2 * off + (P[off] < 0 ? 1 : 0);
  const CubeFace& n = kCubeFaces[nf];
  const long long sc = n.s_sign * P[n.s_axis], tc = n.t_sign * P[n.t_axis];
  return {nf, static_cast<int>((sc + S - 1) / 2), static_cast<int>((tc + S - 1) / 2)};
}

}  // namespace gr::raster
