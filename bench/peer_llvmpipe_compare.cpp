#include "peer_llvmpipe_compare.h"

#include <algorithm>
#include <cmath>

namespace peer {
namespace {

// Triangle `id` (1-based) seen from pixel centre (px, py) in screen coordinates
// (xs = W/2 (1 + x/w), ys = H/2 (1 - y/w)): the smallest signed distance to
// its three edge lines (> 0 inside) and its depth z_ndc there.
struct PixelView {
  double edge_distance;
  double depth;
};

PixelView view_from_pixel(const float* clip, const std::int32_t* tris, int width, int height,
                          std::int32_t id, double px, double py) {
  double x[3], y[3], z[3];
  for (int k = 0; k < 3; ++k) {
    const float* v = clip + 4 * tris[3 * (id - 1) + k];
    const double w = v[3];
    x[k] = 0.5 * width * (1.0 + v[0] / w);
    y[k] = 0.5 * height * (1.0 - v[1] / w);
    z[k] = v[2] / w;
  }
  // E_ab(p) = (px - xa)(yb - ya) - (py - ya)(xb - xa); 2A = E_12(p0).
  auto edge = [&](int a, int b, double qx, double qy) {
    return (qx - x[a]) * (y[b] - y[a]) - (qy - y[a]) * (x[b] - x[a]);
  };
  const double area2 = edge(1, 2, x[0], y[0]);
  const double sign = area2 < 0 ? -1.0 : 1.0;
  double distance = 1e300;
  const int ends[3][2] = {{1, 2}, {2, 0}, {0, 1}};
  double e[3];
  for (int k = 0; k < 3; ++k) {
    const int a = ends[k][0], b = ends[k][1];
    e[k] = edge(a, b, px, py);
    const double length = std::hypot(x[b] - x[a], y[b] - y[a]);
    distance = std::min(distance, sign * e[k] / std::max(length, 1e-300));
  }
  const double u = e[1] / area2, v = e[2] / area2;  // u = E_20/2A, v = E_01/2A
  return {distance, (1.0 - u - v) * z[0] + u * z[1] + v * z[2]};
}

}  // namespace

Agreement compare_gbuffers(const float* clip, const std::int32_t* tris, int width, int height,
                           const GBufferView& a, const GBufferView& b) {
  Agreement r;
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const std::size_t i = std::size_t(row) * width + col;
      const std::int32_t ia = a.tri_id[i], ib = b.tri_id[i];
      if (ia == 0 && ib == 0) continue;
      ++r.either_covered;
      if (ia == ib) {
        ++r.same_id;
        if (a.uv && b.uv) {
          const double du = std::fabs(a.uv[2 * i] - b.uv[2 * i]);
          const double dv = std::fabs(a.uv[2 * i + 1] - b.uv[2 * i + 1]);
          r.max_du = std::max(r.max_du, du);
          r.max_dv = std::max(r.max_dv, dv);
          r.mean_du += du;
          r.mean_dv += dv;
        }
        r.max_ddepth = std::max(r.max_ddepth, double(std::fabs(a.depth[i] - b.depth[i])));
        continue;
      }
      if (ib == 0) ++r.only_a;
      else if (ia == 0) ++r.only_b;
      else ++r.different_id;
      const double px = col + 0.5, py = row + 0.5;
      double nearest = 1e300;
      PixelView va{1e300, 0}, vb{1e300, 0};
      if (ia) nearest = std::min(nearest, std::fabs((va = view_from_pixel(clip, tris, width, height, ia, px, py)).edge_distance));
      if (ib) nearest = std::min(nearest, std::fabs((vb = view_from_pixel(clip, tris, width, height, ib, px, py)).edge_distance));
      if (va.edge_distance < -kEdgeTolerance || vb.edge_distance < -kEdgeTolerance) {
        ++r.disagree_outside;
      } else if (nearest <= kEdgeTolerance) {
        ++r.disagree_at_edge;
      } else {
        ++r.disagree_inside;
        r.max_depth_gap_inside = std::max(r.max_depth_gap_inside, std::fabs(va.depth - vb.depth));
      }
    }
  }
  if (r.same_id) {
    r.mean_du /= double(r.same_id);
    r.mean_dv /= double(r.same_id);
  }
  return r;
}

}  // namespace peer
