// Vertex projection, triangle classification
// and watertight edge setup for the rasterizer (see rasterize_setup.h).
#include "raster/detail/rasterize_setup.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"

namespace gr::raster::detail {

template <class T>
Vertices project_vertices(const T* clip, std::int64_t n, int width, int height, bool y_up) {
  Vertices v;
  project_vertices_into(clip, n, width, height, &v, y_up);
  return v;
}

namespace {

// One vertex's (x, y, z, w) in one register of four doubles (GCC / Clang
// vector extensions: IEEE operations lane by lane, comparisons give masks,
// `mask ? a : b` selects; two SSE registers where there is no AVX).
typedef double Row4 __attribute__((vector_size(32)));
typedef std::int64_t Mask4 __attribute__((vector_size(32)));
typedef float Row4f __attribute__((vector_size(16)));

Row4 load_row(const double* p) {
  Row4 r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
Row4 load_row(const float* p) {
  Row4f r;
  std::memcpy(&r, p, sizeof r);
  return __builtin_convertvector(r, Row4);
}

}  // namespace

template <class T>
void project_vertices_into(const T* clip, std::int64_t n, int width, int height, Vertices* out, bool y_up) {
  Vertices& v = *out;
  // resize() keeps the capacity, and writes nothing when the size is unchanged.
  v.clip.resize(4 * n);
  v.screen.resize(3 * n);
  v.front.resize(n);
  v.outcode.resize(n);
  const double hw = 0.5 * width, hh = 0.5 * height;
  // Per vertex, the four coordinates at once (issue 31: the projection was a
  // fixed cost of every view), each lane the scalar expression's IEEE value:
  //   y seen negated with y_up (the sign bit flipped, as -y does);
  //   sx = hw (1 + x / w), sy = hh (1 - y / w) = hh (1 + (-(y / w))), zn = z / w;
  //   outcode bit k set when the vertex is beyond plane k (rasterize_setup.h).
  const Mask4 flip_y = {0, y_up ? std::numeric_limits<std::int64_t>::min() : 0, 0, 0};
  const Row4 sign_xy = {1.0, -1.0, 1.0, 1.0}, one_xy = {1.0, 1.0, 0.0, 0.0}, half_size = {hw, hh, 1.0, 1.0};
  const Mask4 xy_lanes = {-1, -1, 0, 0};
  const Mask4 beyond_pos = {1 << 1, 1 << 3, 1 << 6, 0}, beyond_neg = {1 << 2, 1 << 4, 1 << 5, 0};
  double* const out_clip = v.clip.data();
  double* const out_screen = v.screen.data();
  std::uint8_t* const out_front = v.front.data();
  std::uint8_t* const out_code = v.outcode.data();
  parallel_for(0, n, 8192, [=](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      const Row4 c = Row4(Mask4(load_row(clip + 4 * i)) ^ flip_y);
      std::memcpy(out_clip + 4 * i, &c, sizeof c);
      const double w = c[3];
      // Project only what is in front of the near plane; the rest is clipped.
      const bool in_front = w > 0.0 && c[2] >= -w;
      const Row4 q = c / w;  // (x / w, y / w, z / w, 1)
      const Row4 s = xy_lanes ? half_size * (one_xy + q * sign_xy) : q;
      const Mask4 finite = (s - s) == 0.0;  // inf - inf and NaN - NaN are NaN
      const bool ok = in_front && (finite[0] & finite[1] & finite[2]) != 0;
      out_screen[3 * i + 0] = ok ? s[0] : 0.0;
      out_screen[3 * i + 1] = ok ? s[1] : 0.0;
      out_screen[3 * i + 2] = ok ? s[2] : 0.0;
      out_front[i] = ok;
      const Mask4 code = ((c > w) & beyond_pos) | ((c < -w) & beyond_neg);
      out_code[i] = static_cast<std::uint8_t>((w <= 0.0) | code[0] | code[1] | code[2]);
    }
  });
}

std::shared_ptr<Vertices> pooled_vertices() {
  // Never destroyed: a G-buffer alive at exit may still give one back.
  static ScratchPool<Vertices>* const pool = new ScratchPool<Vertices>(kPooledVertices);
  auto lease = std::make_shared<ScratchPool<Vertices>::Lease>(pool->take());
  return std::shared_ptr<Vertices>(lease, &**lease);  // owns the lease, points at its Vertices
}

namespace {

// Clips a convex polygon (clip coords, 4 doubles each; n <= N of them)
// against dist(v) >= 0. In exact arithmetic that adds at most one vertex,
// but a crossing computed in floating point may land on the wrong side of
// the next plane (a near-plane crossing rounding to w = 0), so the signs of
// the next clip can alternate: k kept vertices and at most 2 min(k, n - k)
// crossings, at most 3n/2 in all (a quadrilateral: 2 kept + 4 crossings).
template <int N, int M, class Dist>
int clip_polygon(const double (&in)[N][4], int n, double (&out)[M][4], Dist dist) {
  static_assert(M >= 3 * N / 2, "clip_polygon: the output must hold 3/2 of the input's vertices");
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const double* a = in[i];
    const double* b = in[(i + 1) % n];
    const double da = dist(a), db = dist(b);
    // Keep a if inside; add the crossing point if the edge crosses the plane.
    if (da >= 0.0) {
      std::copy(a, a + 4, out[m++]);
    }
    if ((da >= 0.0) != (db >= 0.0)) {
      const double t = da / (da - db);
      for (int k = 0; k < 4; ++k) out[m][k] = a[k] + t * (b[k] - a[k]);
      ++m;
    }
  }
  return m;
}

// Pixel-centre index range [lo, hi] of the interval [a, b], clamped to [0, n-1].
inline void pixel_range(double a, double b, int n, std::int32_t* lo, std::int32_t* hi) {
  // std::max(a, lo) is (a < lo ? lo : a): the same clamp, without branches.
  a = std::min(std::max(a, -2.0), n + 2.0);
  b = std::min(std::max(b, -2.0), n + 2.0);
  // Exact floor/ceil of values in [-2.5, n + 1.5] without a libm call:
  // conversion truncates towards zero, then one compare fixes the direction.
  const double lo_f = a - 0.5, hi_f = b - 0.5;
  int lo_i = static_cast<int>(lo_f), hi_i = static_cast<int>(hi_f);
  lo_i += lo_i < lo_f;  // ceil
  hi_i -= hi_i > hi_f;  // floor
  *lo = std::max(0, lo_i);
  *hi = std::min(n - 1, hi_i);
}

// Canonical order of two vertices: by position, then by index.
bool screen_less(const Vertices& v, std::int32_t a, std::int32_t b) {
  const double* pa = &v.screen[3 * static_cast<std::size_t>(a)];
  const double* pb = &v.screen[3 * static_cast<std::size_t>(b)];
  if (pa[0] != pb[0]) return pa[0] < pb[0];
  if (pa[1] != pb[1]) return pa[1] < pb[1];
  return a < b;
}
bool clip_less(const Vertices& v, std::int32_t a, std::int32_t b) {
  const double* pa = &v.clip[4 * static_cast<std::size_t>(a)];
  const double* pb = &v.clip[4 * static_cast<std::size_t>(b)];
  for (int k : {0, 1, 3})
    if (pa[k] != pb[k]) return pa[k] < pb[k];
  return a < b;
}

// Top-left rule: on e == 0 the pixel is inside if the inside lies towards +x,
// or (horizontal edge) towards +y, i.e. the gradient (dy, -dx) points there.
// (Bitwise on the comparisons: no branch to mispredict on random edge directions.)
bool tie_rule(double dx, double dy) { return (dy > 0.0) | ((dy == 0.0) & (dx < 0.0)); }

// Screen-space edge from pa to pb (screen x, y; already in canonical order)
// times sign, written field by field into *e: an Edge built on the stack and
// copied whole made the copy's wide loads wait on the narrow store of `tie`
// (a store-forwarding stall: the 1.1M-triangle bunny took 16% longer, 1 thread).
void edge_between(const double* pa, const double* pb, double sign, Edge* e) {
  e->ax = pa[0];
  e->ay = pa[1];
  e->dx = sign * (pb[0] - pa[0]);
  e->dy = sign * (pb[1] - pa[1]);
  e->c = 0.0;
  e->mu = e->mz = 0.0;
  e->tie = tie_rule(e->dx, e->dy);
}

// Screen-space edge a->b times sign: e = sign * E_ab(p).
Edge screen_edge(const Vertices& v, std::int32_t a, std::int32_t b, double sign) {
  if (screen_less(v, b, a)) {
    std::swap(a, b);
    sign = -sign;
  }
  Edge e;
  edge_between(&v.screen[3 * static_cast<std::size_t>(a)], &v.screen[3 * static_cast<std::size_t>(b)], sign, &e);
  return e;
}

// Homogeneous edge a->b times sign: e = sign * det[s, V_a, V_b], s = (px, py, 1).
Edge homogeneous_edge(const Vertices& v, std::int32_t a, std::int32_t b, double sign, int width,
                      int height) {
  if (clip_less(v, b, a)) {
    std::swap(a, b);
    sign = -sign;
  }
  const HVec n = cross(homogeneous(v, a, width, height), homogeneous(v, b, width, height));
  Edge e{};
  e.ax = 0.0;
  e.ay = 0.0;
  e.dy = sign * n.x;
  e.dx = -(sign * n.y);
  e.c = sign * n.w;
  e.tie = tie_rule(e.dx, e.dy);
  return e;
}

// Twice the signed screen area, 2A = E_12(p0).
double twice_area(const Vertices& v, const std::int32_t* tri) {
  const double* p0 = &v.screen[3 * static_cast<std::size_t>(tri[0])];
  const double* p1 = &v.screen[3 * static_cast<std::size_t>(tri[1])];
  const double* p2 = &v.screen[3 * static_cast<std::size_t>(tri[2])];
  return (p0[0] - p1[0]) * (p2[1] - p1[1]) - (p0[1] - p1[1]) * (p2[0] - p1[0]);
}

double homogeneous_det(const Vertices& v, const std::int32_t* tri, int width, int height) {
  return dot(homogeneous(v, tri[0], width, height),
             cross(homogeneous(v, tri[1], width, height), homogeneous(v, tri[2], width, height)));
}

}  // namespace

TriClass classify_triangle(const Vertices& v, const std::int32_t* tri, int width, int height,
                           int cull, PixelBox* box) {
  // Entirely outside one frustum plane (including behind the camera).
  if (v.outcode[tri[0]] & v.outcode[tri[1]] & v.outcode[tri[2]]) return TriClass::Outside;

  // Orientation: 2A > 0 (screen) or D < 0 (homogeneous) is a front face.
  const bool clipped = needs_clipping(v, tri);
  bool front;
  if (!clipped) {
    const double a2 = twice_area(v, tri);
    if (a2 == 0.0) return TriClass::ZeroArea;
    front = a2 > 0.0;
  } else {
    const double d = homogeneous_det(v, tri, width, height);
    if (d == 0.0 || !std::isfinite(d)) return TriClass::ZeroArea;
    front = d < 0.0;
  }
  if ((cull > 0 && !front) || (cull < 0 && front)) return TriClass::Face;

  // Screen bounding box: of the vertices, or of the near-clipped polygon.
  double minx, maxx, miny, maxy;
  if (!clipped) {
    const double* p[3] = {&v.screen[3 * static_cast<std::size_t>(tri[0])],
                          &v.screen[3 * static_cast<std::size_t>(tri[1])],
                          &v.screen[3 * static_cast<std::size_t>(tri[2])]};
    minx = std::min({p[0][0], p[1][0], p[2][0]});
    maxx = std::max({p[0][0], p[1][0], p[2][0]});
    miny = std::min({p[0][1], p[1][1], p[2][1]});
    maxy = std::max({p[0][1], p[1][1], p[2][1]});
  } else {
    double poly[3][4], near[4][4], pos[6][4];  // clip_polygon's bound: 3/2 of the input
    for (int k = 0; k < 3; ++k) {
      const double* c = &v.clip[4 * static_cast<std::size_t>(tri[k])];
      std::copy(c, c + 4, poly[k]);
    }
    // Sutherland-Hodgman against the near plane z >= -w ...
    const int n1 = clip_polygon(poly, 3, near, [](const double* p) { return p[2] + p[3]; });
    // ... and against w >= eps so every remaining vertex projects.
    double wmax = 0.0;
    for (int k = 0; k < n1; ++k) wmax = std::max(wmax, std::abs(near[k][3]));
    const double eps = 1e-12 * wmax;
    const int n2 = clip_polygon(near, n1, pos, [eps](const double* p) { return p[3] - eps; });
    if (n2 == 0) return TriClass::Outside;
    minx = miny = INFINITY;
    maxx = maxy = -INFINITY;
    for (int k = 0; k < n2; ++k) {
      const double sx = 0.5 * width * (1.0 + pos[k][0] / pos[k][3]);
      const double sy = 0.5 * height * (1.0 - pos[k][1] / pos[k][3]);
      minx = std::min(minx, sx);
      maxx = std::max(maxx, sx);
      miny = std::min(miny, sy);
      maxy = std::max(maxy, sy);
    }
    // One pixel of margin for the rounding of the clipped vertices.
    minx -= 1.0;
    miny -= 1.0;
    maxx += 1.0;
    maxy += 1.0;
  }
  pixel_range(minx, maxx, width, &box->x0, &box->x1);
  pixel_range(miny, maxy, height, &box->y0, &box->y1);
  if (box->x0 > box->x1 || box->y0 > box->y1) return TriClass::NoPixel;
  return clipped ? TriClass::Clipped : TriClass::Raster;
}

namespace {

// The edges half of setup_edges for a triangle with every vertex in front; returns 2A.
double setup_screen_edges(const Vertices& v, const std::int32_t* tri, TriSetup* out) {
  // Screen form: e_k = sign(2A) E_ab; screen_edge per edge, written in place
  // (this runs per triangle and tile).
  const double* p[3] = {&v.screen[3 * static_cast<std::size_t>(tri[0])],
                        &v.screen[3 * static_cast<std::size_t>(tri[1])],
                        &v.screen[3 * static_cast<std::size_t>(tri[2])]};
  const double a2 = (p[0][0] - p[1][0]) * (p[2][1] - p[1][1]) - (p[0][1] - p[1][1]) * (p[2][0] - p[1][0]);
  const double sign = a2 > 0.0 ? 1.0 : -1.0;
  for (int k = 0; k < 3; ++k) {
    const int ia = k == 2 ? 0 : k + 1, ib = k == 0 ? 2 : k - 1;
    const double *pa = p[ia], *pb = p[ib];
    // Canonical order (screen_less): by x, then y, then vertex index, as
    // selections rather than branches (the order is random per edge).
    const bool swap = (pb[0] < pa[0]) | ((pb[0] == pa[0]) & ((pb[1] < pa[1]) | ((pb[1] == pa[1]) & (tri[ib] < tri[ia]))));
    edge_between(swap ? pb : pa, swap ? pa : pb, swap ? -sign : sign, &out->e[k]);
  }
  return a2;
}

}  // namespace

void setup_screen_weights(const Vertices& v, const std::int32_t* tri, double a2, TriSetup* out) {
  // lambda_k = e_k / |2A|, depth = sum lambda_k z_k.
  const double inv = 1.0 / std::abs(a2);
  bool z_test = false;
  for (int k = 0; k < 3; ++k) {
    const double z = v.screen[3 * static_cast<std::size_t>(tri[k]) + 2];
    out->e[k].mu = inv;
    out->e[k].mz = z * inv;
    z_test |= z > 1.0;
  }
  out->z_test = z_test;
}

void setup_edges(const Vertices& v, const std::int32_t* tri, int width, int height, TriSetup* out) {
  if (!needs_clipping(v, tri)) {
    setup_screen_weights(v, tri, setup_screen_edges(v, tri, out), out);
    return;
  }
  // Homogeneous form: inside iff F_k / D > 0, with F_k = det[s, V_a, V_b].
  // Edges whose two vertices are in front use the screen form instead
  // (F_k = -w_a w_b E_ab), so they match the neighbouring triangle bit for bit.
  const double d = homogeneous_det(v, tri, width, height);
  const double sign = d > 0.0 ? 1.0 : -1.0;
  const double inv = 1.0 / std::abs(d);
  for (int k = 0; k < 3; ++k) {
    const std::int32_t a = tri[(k + 1) % 3], b = tri[(k + 2) % 3];
    const double* ck = &v.clip[4 * static_cast<std::size_t>(tri[k])];
    Edge& e = out->e[k];
    double base;
    if (v.front[a] && v.front[b]) {
      e = screen_edge(v, a, b, -sign);
      base = v.clip[4 * static_cast<std::size_t>(a) + 3] * v.clip[4 * static_cast<std::size_t>(b) + 3];
    } else {
      e = homogeneous_edge(v, a, b, sign, width, height);
      base = 1.0;
    }
    // F_k / D = e * base / |D|; lambda_k = w_k F_k / D; depth = sum z_k F_k / D.
    e.mu = base * ck[3] * inv;
    e.mz = base * ck[2] * inv;
  }
  out->z_test = true;
}

template Vertices project_vertices<float>(const float*, std::int64_t, int, int, bool);
template Vertices project_vertices<double>(const double*, std::int64_t, int, int, bool);
template void project_vertices_into<float>(const float*, std::int64_t, int, int, Vertices*, bool);
template void project_vertices_into<double>(const double*, std::int64_t, int, int, Vertices*, bool);

}  // namespace gr::raster::detail
