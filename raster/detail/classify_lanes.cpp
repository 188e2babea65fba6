#include "raster/detail/classify_lanes.h"

#include <cstddef>
#include <cstring>

#include "raster/detail/rasterize_scan.h"

namespace gr::raster::detail {
namespace {

// A register of doubles (four with AVX, else two), with GCC / Clang vector
// extensions: the operators act lane by lane with scalar IEEE semantics,
// comparisons give masks (all bits set for true), `mask ? a : b` selects.
#ifdef __AVX__
constexpr int kWidth = 4;
#else
constexpr int kWidth = 2;
#endif
typedef double Vd __attribute__((vector_size(8 * kWidth)));
typedef std::int64_t Vm __attribute__((vector_size(8 * kWidth)));
typedef std::int32_t Vi __attribute__((vector_size(4 * kWidth)));
static_assert(kClassifyLanes % kWidth == 0, "whole vectors of lanes");

Vd splat(double x) { return Vd{} + x; }
Vd load(const double* p) {
  Vd v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
// Vertex indices (int32, exact in double).
Vd load_index(const std::int32_t* p) {
  Vi v;
  std::memcpy(&v, p, sizeof v);
  return __builtin_convertvector(v, Vd);
}
Vm load_mask(const std::int64_t* p) {
  Vm m;
  std::memcpy(&m, p, sizeof m);
  return m;
}
Vm splat_class(TriClass c) { return Vm{} + static_cast<std::int64_t>(c); }
// As std::min / std::max pick them.
Vd vmin(Vd a, Vd b) { return b < a ? b : a; }
Vd vmax(Vd a, Vd b) { return a < b ? b : a; }
Vd as_flag(Vm m) { return m ? splat(1.0) : splat(0.0); }

// classify_triangle's pixel_range: the index range [lo, hi] of the pixel
// centres in [a, b] (clamped to [-2, n + 2]: exact floor / ceil by truncation
// and one compare), clamped to [0, n - 1].
void centre_range(Vd a, Vd b, double n, Vd& lo, Vd& hi) {
  a = vmin(vmax(a, splat(-2.0)), splat(n + 2.0)) - 0.5;
  b = vmin(vmax(b, splat(-2.0)), splat(n + 2.0)) - 0.5;
  const Vd a_t = __builtin_convertvector(__builtin_convertvector(a, Vi), Vd);
  const Vd b_t = __builtin_convertvector(__builtin_convertvector(b, Vi), Vd);
  lo = vmax(splat(0.0), a_t + as_flag(a_t < a));
  hi = vmin(splat(n - 1.0), b_t - as_flag(b_t > b));
}

// One screen edge from corner a to corner b of triangles of orientation
// `sign`, as setup_screen_edges (rasterize_setup.cpp) builds it: the two vertices in canonical order
// (by x, then y, then vertex index), the difference times the sign, and the
// top-left rule's tie.
struct LaneEdge {
  Vd ax, ay, dx, dy;
  Vm tie;
};
LaneEdge lane_edge(Vd xa, Vd ya, Vd ia, Vd xb, Vd yb, Vd ib, Vd sign) {
  const Vm swap = (xb < xa) | ((xb == xa) & ((yb < ya) | ((yb == ya) & (ib < ia))));
  LaneEdge e;
  e.ax = swap ? xb : xa;
  e.ay = swap ? yb : ya;
  const Vd s = swap ? -sign : sign;
  e.dx = s * ((swap ? xa : xb) - e.ax);
  e.dy = s * ((swap ? ya : yb) - e.ay);
  e.tie = (e.dy > 0.0) | ((e.dy == 0.0) & (e.dx < 0.0));
  return e;
}

// Edge::eval at (px, py) (a screen edge's c is 0) and Edge::inside.
Vd eval(const LaneEdge& e, Vd px, Vd py) { return ((px - e.ax) * e.dy - (py - e.ay) * e.dx) + 0.0; }
Vm inside(const LaneEdge& e, Vd value) { return (value > 0.0) | ((value == 0.0) & e.tie); }

}  // namespace

void classify_lanes(const Vertices& v, const std::int32_t* tris, std::int64_t t0, int n, int width, int height,
                    int cull, TriClass* k, PixelBox* box, LaneCoverage* cover) {
  // Gather: each corner's screen position and vertex index, one array per
  // corner and coordinate, and whether the three corners share a frustum
  // plane (outside) or one is not in front of the near plane (clipped), as
  // lane masks (lanes past n hold a harmless zero triangle).
  double x[3][kClassifyLanes], y[3][kClassifyLanes];
  std::int32_t id[3][kClassifyLanes];
  std::int64_t outside[kClassifyLanes], clipped[kClassifyLanes];
  const double* const screen = v.screen.data();
  const std::uint8_t *const outcode = v.outcode.data(), *const in_front = v.front.data();
  for (int i = 0; i < n; ++i) {
    const std::int32_t* tri = tris + 3 * (t0 + i);
    for (int c = 0; c < 3; ++c) {
      const double* s = screen + 3 * static_cast<std::size_t>(tri[c]);
      x[c][i] = s[0];
      y[c][i] = s[1];
      id[c][i] = tri[c];
    }
    outside[i] = (outcode[tri[0]] & outcode[tri[1]] & outcode[tri[2]]) != 0 ? -1 : 0;
    clipped[i] = (in_front[tri[0]] & in_front[tri[1]] & in_front[tri[2]]) == 0 ? -1 : 0;
  }
  for (int i = n; i < kClassifyLanes; ++i) {
    for (int c = 0; c < 3; ++c) x[c][i] = y[c][i] = 0.0, id[c][i] = 0;
    outside[i] = clipped[i] = 0;
  }
  // classify_triangle's facing test: front faces have 2A > 0.
  auto facing_culled = [cull](Vm front) { return cull > 0 ? ~front : cull < 0 ? front : Vm{}; };

  // The arithmetic of classify_triangle and of the scan's coverage test at
  // the centres of small boxes, four triangles at a time.
  double* const area2 = cover->area2;
  double x0s[kClassifyLanes], x1s[kClassifyLanes], y0s[kClassifyLanes], y1s[kClassifyLanes];
  std::int64_t cls[kClassifyLanes];
  for (int i = 0; i < kClassifyLanes; i += kWidth) {
    const Vd x0 = load(&x[0][i]), x1 = load(&x[1][i]), x2 = load(&x[2][i]);
    const Vd y0 = load(&y[0][i]), y1 = load(&y[1][i]), y2 = load(&y[2][i]);
    const Vd i0 = load_index(&id[0][i]), i1 = load_index(&id[1][i]), i2 = load_index(&id[2][i]);
    const Vd a2 = (x0 - x1) * (y2 - y1) - (y0 - y1) * (x2 - x1);
    Vd bx0, bx1, by0, by1;
    centre_range(vmin(vmin(x0, x1), x2), vmax(vmax(x0, x1), x2), width, bx0, bx1);
    centre_range(vmin(vmin(y0, y1), y2), vmax(vmax(y0, y1), y2), height, by0, by1);
    // The centres of a box of at most kMaxFragmentBox (slot s: column s mod w,
    // row s / w) against the three edges.
    const Vd w = bx1 - bx0 + 1.0, h = by1 - by0 + 1.0, area = w * h;
    // Only the slots of non-empty boxes of at most kMaxFragmentBox centres
    // are read (the tail and lane_fragments); the others are left at zero.
    // Boxes of more centres (most, once triangles span a few pixels) leave
    // them to the tiles' scan, and the vector stops at its largest small box
    // (one centre or none at most, for triangles below a pixel): issue 31.
    const Vd used = ((w >= 1.0) & (h >= 1.0) & (area <= double(kMaxFragmentBox))) ? area : splat(0.0);
    double most = 0.0;
    for (int j = 0; j < kWidth; ++j) most = used[j] > most ? used[j] : most;
    const int n_slots = static_cast<int>(most);
    Vm slots = Vm{};
    if (n_slots > 0) {
      const Vd sign = a2 > 0.0 ? splat(1.0) : splat(-1.0);
      const LaneEdge e0 = lane_edge(x1, y1, i1, x2, y2, i2, sign);
      const LaneEdge e1 = lane_edge(x2, y2, i2, x0, y0, i0, sign);
      const LaneEdge e2 = lane_edge(x0, y0, i0, x1, y1, i1, sign);
      for (int s = 0; s < n_slots; ++s) {
        const Vd slot = splat(s);
        const Vd row = as_flag(slot >= w) + as_flag(slot >= 2.0 * w) + as_flag(slot >= 3.0 * w);
        const Vd px = (bx0 + (slot - row * w)) + 0.5, py = (by0 + row) + 0.5;
        const Vd v0 = eval(e0, px, py), v1 = eval(e1, px, py), v2 = eval(e2, px, py);
        const Vm covered = (slot < used) & inside(e0, v0) & inside(e1, v1) & inside(e2, v2);
        slots |= covered & (std::int64_t(1) << s);
        std::memcpy(&cover->e[s][0][i], &v0, sizeof v0);
        std::memcpy(&cover->e[s][1][i], &v1, sizeof v1);
        std::memcpy(&cover->e[s][2][i], &v2, sizeof v2);
      }
    }
    for (int j = 0; j < kWidth; ++j) cover->slots[i + j] = static_cast<std::uint8_t>(slots[j]);
    // classify_triangle's outcome, its first test deciding: frustum, clipping,
    // area, facing, box; a small box none of whose centres is covered is
    // NoPixel too (larger: the tiles' scan decides).
    Vm c = splat_class(TriClass::Raster);
    c = ((used > 0.0) & (slots == 0)) ? splat_class(TriClass::NoPixel) : c;
    c = ((w < 1.0) | (h < 1.0)) ? splat_class(TriClass::NoPixel) : c;
    c = facing_culled(a2 > 0.0) ? splat_class(TriClass::Face) : c;
    c = a2 == 0.0 ? splat_class(TriClass::ZeroArea) : c;
    c = load_mask(&clipped[i]) ? splat_class(TriClass::Clipped) : c;
    c = load_mask(&outside[i]) ? splat_class(TriClass::Outside) : c;
    std::memcpy(&cls[i], &c, sizeof c);
    std::memcpy(&area2[i], &a2, sizeof a2);
    std::memcpy(&x0s[i], &bx0, sizeof bx0);
    std::memcpy(&x1s[i], &bx1, sizeof bx1);
    std::memcpy(&y0s[i], &by0, sizeof by0);
    std::memcpy(&y1s[i], &by1, sizeof by1);
  }

  for (int i = 0; i < n; ++i) {
    box[i] = {static_cast<std::int32_t>(x0s[i]), static_cast<std::int32_t>(y0s[i]), static_cast<std::int32_t>(x1s[i]),
              static_cast<std::int32_t>(y1s[i])};
    k[i] = static_cast<TriClass>(cls[i]);
  }
}

int lane_fragments(const Vertices& v, const std::int32_t* tris, std::int32_t t, const PixelBox& b,
                   const LaneCoverage& cover, int lane, int tiles_x, Fragment* out) {
  // The weights (a division) of setup_edges; the edge values come from the lanes.
  TriSetup s;
  setup_screen_weights(v, tris + 3 * static_cast<std::int64_t>(t), cover.area2[lane], &s);
  const int w = b.x1 - b.x0 + 1;
  int n = 0;
  for (int slot = 0; slot < kMaxFragmentBox; ++slot) {
    if (!(cover.slots[lane] >> slot & 1)) continue;
    const double v0 = cover.e[slot][0][lane], v1 = cover.e[slot][1][lane], v2 = cover.e[slot][2][lane];
    const double z = v0 * s.e[0].mz + v1 * s.e[1].mz + v2 * s.e[2].mz;
    if (s.z_test && !(z >= -1.0 && z <= 1.0)) continue;
    const int x = b.x0 + slot % w, y = b.y0 + slot / w;
    const int tile = (y / kTile) * tiles_x + x / kTile, in_tile = (y % kTile) * kTile + x % kTile;
    out[n++] = {z, v1 * s.e[1].mu, v2 * s.e[2].mu, t, tile * kTilePixels + in_tile};
  }
  return n;
}

}  // namespace gr::raster::detail
