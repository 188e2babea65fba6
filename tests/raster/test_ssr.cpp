// Tests of the SSR tracers (raster/ssr.*): on the analytic scene (mirror floor,
// two spheres and a box) the hits of reflected floor rays match exact ray-sphere /
// ray-box intersections within a pixel for all three tracers; the tracers agree
// with each other and with the dense reference; the DDA visits every pixel along
// the projected ray exactly once at stride 1 (view-space stepping does not);
// rays that leave the screen, point toward the camera or hit nothing return no
// hit and zero fades; degenerate inputs give no NaN; back-face depth removes the
// hits that a thick band invents behind a sphere; results do not depend on the
// thread count.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "ops/tensor/elementwise.h"
#include "ops/render/ssr.h"
#include "ops/render/transforms.h"
#include "raster/ssr.h"
#include "examples/common/ssr_scene.h"
#include "test_support.h"

using namespace gr;
using namespace gr::raster;
using namespace gr::examples;
using Vec3 = std::array<double, 3>;

namespace {

Tensor vec3(const Vec3& v) { return Tensor::from_values({v[0], v[1], v[2]}, {3}, DType::Float64); }

// The SSR scene rendered into a float64 view-space G-buffer.
struct Rendered {
  SsrScene scene;
  int W, H;
  std::int32_t floor_tris;
  std::array<double, 16> view{}, proj{};
  Tensor proj_t;
  SsrGBuffer g;
  // tri_id of pixel (i, j)
  std::int32_t id(int i, int j) const { return g.mask.data<std::int32_t>()[j * W + i]; }
  Vec3 pos(int i, int j) const {
    const double* p = g.position.data<double>() + 3 * (j * W + i);
    return {p[0], p[1], p[2]};
  }
  Vec3 nrm(int i, int j) const {
    const double* p = g.normal.data<double>() + 3 * (j * W + i);
    return {p[0], p[1], p[2]};
  }
  // View-space point -> world (the view matrix is rigid: inverse = transpose of R).
  Vec3 to_world(const Vec3& p, bool direction) const {
    Vec3 q = p;
    if (!direction)
      for (int a = 0; a < 3; ++a) q[a] -= view[4 * a + 3];
    Vec3 w{};
    for (int a = 0; a < 3; ++a) w[a] = view[a] * q[0] + view[4 + a] * q[1] + view[8 + a] * q[2];
    return w;
  }
  Vec3 to_view(const Vec3& w) const {
    Vec3 p{};
    for (int a = 0; a < 3; ++a) p[a] = view[4 * a] * w[0] + view[4 * a + 1] * w[1] + view[4 * a + 2] * w[2] + view[4 * a + 3];
    return p;
  }
};

Rendered render(int W, int H, bool objects = true, bool back_faces = false) {
  Rendered r;
  r.W = W, r.H = H;
  r.scene = make_ssr_scene(8, 4);
  r.floor_tris = 2 * 8 * 8;
  const Tensor view = look_at(vec3(r.scene.eye), vec3(r.scene.target), vec3(r.scene.up));
  r.proj_t = perspective(r.scene.fov_y, double(W) / H, r.scene.near, r.scene.far, ClipSpace::OpenGL, DType::Float64);
  const auto v = view.to_vector(), p = r.proj_t.to_vector();
  std::copy(v.begin(), v.end(), r.view.begin());
  std::copy(p.begin(), p.end(), r.proj.begin());
  Tensor pos = cast(r.scene.mesh.positions, DType::Float64), nrm = cast(r.scene.mesh.normals, DType::Float64);
  Tensor tris = r.scene.mesh.triangles, col = cast(r.scene.colours, DType::Float64);
  if (!objects) {
    // Floor only: its vertices come first; keep its triangles.
    tris = Tensor::from_vector(std::vector<std::int32_t>(tris.data<std::int32_t>(), tris.data<std::int32_t>() + 3 * r.floor_tris),
                               {r.floor_tris, 3});
  }
  const ViewSpaceMesh vs = ssr_view_space(pos, nrm, view);
  r.g = ssr_gbuffer(vs.positions, vs.normals, col, tris, r.proj_t, {W, H, back_faces});
  return r;
}

// Parameters over hand-made G-buffer arrays (W x H) and the outputs hit and hit_xy.
SsrParams<double> params_of(int W, int H, const std::vector<double>& projection, const std::vector<double>& pos,
                            const std::vector<double>& nrm, const std::vector<std::int32_t>& mask,
                            std::vector<double>& hit, std::vector<double>& xy) {
  SsrParams<double> p;
  p.width = W, p.height = H;
  std::copy(projection.begin(), projection.end(), p.projection.begin());
  p.position = pos.data(), p.normal = nrm.data(), p.mask = mask.data();
  hit.assign(std::size_t(W) * H, 0.0), xy.assign(2 * std::size_t(W) * H, 0.0);
  p.hit = hit.data(), p.hit_xy = xy.data();
  return p;
}

SsrParams<double> params_of(const Rendered& r) {
  SsrParams<double> p;
  p.width = r.W, p.height = r.H;
  p.projection = r.proj;
  p.position = r.g.position.data<double>();
  p.normal = r.g.normal.data<double>();
  p.mask = r.g.mask.data<std::int32_t>();
  if (r.g.back_z.defined()) {
    p.back_z = r.g.back_z.data<double>();
    p.back_mask = r.g.back_mask.data<std::int32_t>();
  }
  return p;
}

struct Outputs {
  std::vector<double> hit, xy, dist, point, edge, fade;
  SsrStats stats;
};
Outputs trace_all(const Rendered& r, const SsrOptions& o) {
  const std::size_t n = std::size_t(r.W) * r.H;
  Outputs out{std::vector<double>(n), std::vector<double>(2 * n), std::vector<double>(n), std::vector<double>(3 * n),
              std::vector<double>(n), std::vector<double>(n), {}};
  SsrParams<double> p = params_of(r);
  p.hit = out.hit.data(), p.hit_xy = out.xy.data(), p.hit_distance = out.dist.data();
  p.hit_position = out.point.data(), p.edge_fade = out.edge.data(), p.distance_fade = out.fade.data();
  out.stats = ssr_trace(p, o);
  return out;
}

// Nearest positive ray parameter of a world-space ray against the spheres and the box (inf if none).
double intersect_scene(const SsrScene& s, const Vec3& o, const Vec3& d) {
  double best = INFINITY;
  for (const SsrSphere& sp : s.spheres) {
    const Vec3 oc{o[0] - sp.centre[0], o[1] - sp.centre[1], o[2] - sp.centre[2]};
    const double b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
    const double c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - sp.radius * sp.radius;
    const double disc = b * b - c;
    if (disc < 0) continue;
    const double t = -b - std::sqrt(disc);
    if (t > 1e-6) best = std::min(best, t);
  }
  double t0 = -INFINITY, t1 = INFINITY;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < s.box_min[a] || o[a] > s.box_max[a]) t0 = INFINITY;
      continue;
    }
    double ta = (s.box_min[a] - o[a]) / d[a], tb = (s.box_max[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
  }
  if (t0 <= t1 && t0 > 1e-6) best = std::min(best, t0);
  return best;
}

struct Analytic {
  bool hit = false, visible = false;
  double x = 0, y = 0;
};
// Exact first intersection of pixel (i, j)'s reflected ray, its screen position and
// whether the depth buffer sees that point (the G-buffer depth there matches it).
Analytic analytic_hit(const Rendered& r, int i, int j, double max_distance) {
  Analytic a;
  const SsrRay ray = ssr_ray(r.pos(i, j), r.nrm(i, j), r.scene.near, max_distance);
  if (!ray.valid) return a;
  const Vec3 o = r.to_world(ray.origin, false), d = r.to_world(ray.dir, true);
  const double t = intersect_scene(r.scene, o, d);
  if (!(t <= ray.length)) return a;
  a.hit = true;
  const Vec3 xw{o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
  const Vec3 xv = r.to_view(xw);
  if (!ssr_project(r.proj, r.W, r.H, xv, a.x, a.y)) return a;
  if (a.x < 0 || a.y < 0 || a.x >= r.W || a.y >= r.H) return a;
  const int pi = int(a.x), pj = int(a.y);
  a.visible = r.id(pi, pj) > r.floor_tris && std::abs(r.pos(pi, pj)[2] - xv[2]) < 0.05;
  return a;
}

SsrOptions base_options() {
  SsrOptions o;
  o.near = 0.1;
  o.max_distance = 8;
  o.thickness = 0.3;
  return o;
}

SsrOptions tracer_options(SsrTracer t) {
  SsrOptions o = base_options();
  o.tracer = t;
  if (t == SsrTracer::ViewSpace) o.max_steps = 400, o.binary_steps = 10;
  if (t == SsrTracer::Dda) o.max_steps = 400, o.binary_steps = 8, o.stride = 1;
  return o;
}

const char* name_of(SsrTracer t) {
  return t == SsrTracer::ViewSpace ? "view-space" : t == SsrTracer::Dda ? "dda" : "reference";
}

}  // namespace

TEST_CASE("ssr: reflected floor rays hit the spheres and the box where the exact intersection projects, "
          "within a pixel (99%, and 1.5 px at worst), for every tracer",
          "[ssr][raster]") {
  const Rendered r = render(160, 120);
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda, SsrTracer::Reference}) {
    const SsrOptions o = tracer_options(t);
    const Outputs out = trace_all(r, o);
    int compared = 0, within = 0, missed = 0;
    double worst = 0;
    for (int j = 0; j < r.H; ++j)
      for (int i = 0; i < r.W; ++i) {
        const std::int32_t id = r.id(i, j);
        if (id == 0 || id > r.floor_tris) continue;
        const Analytic a = analytic_hit(r, i, j, o.max_distance);
        if (!a.hit || !a.visible) continue;
        const std::size_t k = std::size_t(j) * r.W + i;
        ++compared;
        if (out.hit[k] == 0) {
          ++missed;
          continue;
        }
        const double e = std::hypot(out.xy[2 * k] - a.x, out.xy[2 * k + 1] - a.y);
        worst = std::max(worst, e);
        within += e <= 1.0;
      }
    INFO(name_of(t) << ": compared " << compared << ", within 1 px " << within << ", missed " << missed
                    << ", worst " << worst << " px");
    CHECK(compared > 300);
    // The DDA and the reference find every visible intersection; the view-space
    // march's point test lets a few grazing rays slip through the band.
    CHECK(missed <= (t == SsrTracer::ViewSpace ? compared / 100 : 0));
    CHECK(within >= 0.99 * (compared - missed));
    CHECK(worst <= 1.5);
  }
}

TEST_CASE("ssr: the view-space tracer, the DDA and the dense reference agree on the analytic scene",
          "[ssr][raster]") {
  const Rendered r = render(160, 120);
  const Outputs ref = trace_all(r, tracer_options(SsrTracer::Reference));
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda}) {
    const Outputs out = trace_all(r, tracer_options(t));
    int both = 0, only_ref = 0, only_tracer = 0, close = 0;
    double worst = 0;
    for (std::size_t k = 0; k < out.hit.size(); ++k) {
      if (ref.hit[k] && out.hit[k]) {
        ++both;
        const double e = std::hypot(out.xy[2 * k] - ref.xy[2 * k], out.xy[2 * k + 1] - ref.xy[2 * k + 1]);
        worst = std::max(worst, e);
        close += e <= 1.0;
      } else if (ref.hit[k]) {
        ++only_ref;
      } else if (out.hit[k]) {
        ++only_tracer;
      }
    }
    INFO(name_of(t) << ": both " << both << ", only reference " << only_ref << ", only tracer " << only_tracer
                    << ", within 1 px " << close << ", worst " << worst);
    CHECK(both > 500);
    CHECK(only_ref + only_tracer <= both / 100);
    CHECK(close >= both * 0.97);
  }
}

TEST_CASE("ssr: at stride 1 the DDA visits every pixel along the projected ray once and skips none, "
          "while view-space stepping skips and repeats pixels",
          "[ssr][raster]") {
  const Rendered r = render(160, 120);
  // An empty depth buffer: rays never hit, so the march runs to the clipped end.
  SsrDepth empty;
  empty.width = r.W, empty.height = r.H;
  empty.front.assign(std::size_t(r.W) * r.H, -INFINITY);
  empty.lower = empty.front;
  std::int64_t rays = 0, view_gaps = 0, view_repeats = 0;
  for (double jitter : {0.0, 1.0}) {
    SsrOptions o = base_options();
    o.tracer = SsrTracer::Dda;
    o.max_steps = 100000;
    o.jitter = jitter;
    for (int j = 1; j < r.H; j += 3)
      for (int i = 2; i < r.W; i += 5) {
        if (!r.id(i, j)) continue;
        const SsrRay ray = ssr_ray(r.pos(i, j), r.nrm(i, j), o.near, o.max_distance);
        if (!ray.valid) continue;
        std::vector<std::array<int, 2>> px;
        ssr_trace_ray(empty, r.proj, ray, i, j, o, &px);
        if (px.size() < 2) continue;
        ++rays;
        // All distinct.
        std::set<std::array<int, 2>> unique(px.begin(), px.end());
        REQUIRE(unique.size() == px.size());
        // 8-connected chain starting next to the origin, one step along the major axis each.
        const bool x_major = std::abs(px.back()[0] - i) >= std::abs(px.back()[1] - j);
        std::array<int, 2> prev{i, j};
        for (const auto& q : px) {
          const int dmaj = x_major ? std::abs(q[0] - prev[0]) : std::abs(q[1] - prev[1]);
          const int dmin = x_major ? std::abs(q[1] - prev[1]) : std::abs(q[0] - prev[0]);
          REQUIRE(dmaj == 1);
          REQUIRE(dmin <= 1);
          REQUIRE(q[0] >= 0);
          REQUIRE(q[1] >= 0);
          REQUIRE(q[0] < r.W);
          REQUIRE(q[1] < r.H);
          prev = q;
        }
        // View-space stepping with the same number of samples along the same ray.
        if (jitter == 0) {
          SsrOptions v = o;
          v.tracer = SsrTracer::ViewSpace;
          v.max_steps = int(px.size()) + 1;
          SsrRay clipped = ray;
          std::vector<std::array<int, 2>> vp;
          ssr_trace_ray(empty, r.proj, clipped, i, j, v, &vp);
          std::set<std::array<int, 2>> vu(vp.begin(), vp.end());
          view_repeats += std::int64_t(vp.size() - vu.size());
          std::array<int, 2> pv{i, j};
          for (const auto& q : vp) {
            view_gaps += std::max(std::abs(q[0] - pv[0]), std::abs(q[1] - pv[1])) > 1;
            pv = q;
          }
        }
      }
  }
  INFO("rays " << rays << ", view-space gaps " << view_gaps << ", repeats " << view_repeats);
  CHECK(rays > 400);
  CHECK(view_gaps > 0);
  CHECK(view_repeats > 0);
}

TEST_CASE("ssr: rays that hit nothing or leave the screen return no hit and zero fades on a bare floor",
          "[ssr][raster]") {
  // Without objects every reflected floor ray rises into the empty sky and leaves the screen.
  const Rendered r = render(120, 90, /*objects=*/false);
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda, SsrTracer::Reference}) {
    SsrOptions o = tracer_options(t);
    o.max_distance = 100;
    o.thickness = 10;
    const Outputs out = trace_all(r, o);
    INFO(name_of(t));
    CHECK(out.stats.rays > 3000);
    CHECK(out.stats.hits == 0);
    for (std::size_t k = 0; k < out.hit.size(); ++k) {
      REQUIRE(out.hit[k] == 0);
      REQUIRE(out.edge[k] == 0);
      REQUIRE(out.fade[k] == 0);
      REQUIRE(out.dist[k] == 0);
    }
  }
}

TEST_CASE("ssr: rays reflected toward the camera are clipped at the near plane and find nothing", "[ssr][raster]") {
  // A wall facing the camera, slightly tilted, fills the screen: every reflected ray points back (R.z > 0).
  const int W = 64, H = 48;
  const Tensor proj = perspective(0.9, double(W) / H, 0.1, 50, ClipSpace::OpenGL, DType::Float64);
  std::vector<double> pos(3 * W * H), nrm(3 * W * H);
  std::vector<std::int32_t> mask(W * H, 1);
  const Vec3 n0{0.2, -0.1, 1.0};
  const double ln = std::sqrt(n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]);
  const auto pm = proj.to_vector();
  for (int j = 0; j < H; ++j)
    for (int i = 0; i < W; ++i) {
      // Camera ray through the pixel centre meets the plane n.p = n.(0, 0, -4).
      const double xn = (i + 0.5) / W * 2 - 1, yn = 1 - (j + 0.5) / H * 2;
      const Vec3 d{xn / pm[0], yn / pm[5], -1};
      const double t = (n0[2] * -4) / (n0[0] * d[0] + n0[1] * d[1] + n0[2] * d[2]);
      for (int a = 0; a < 3; ++a) pos[3 * (j * W + i) + a] = t * d[a], nrm[3 * (j * W + i) + a] = n0[a] / ln;
    }
  std::vector<double> hit, xy;
  const SsrParams<double> p = params_of(W, H, pm, pos, nrm, mask, hit, xy);
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda, SsrTracer::Reference}) {
    SsrOptions o = tracer_options(t);
    o.thickness = 100;  // even an absurd band must not make the wall hit itself
    const SsrStats s = ssr_trace(p, o);
    INFO(name_of(t));
    CHECK(s.rays == W * H);
    CHECK(s.hits == 0);
    // The ray really is clipped: its end lies on the near plane.
    const SsrRay ray = ssr_ray({pos[0], pos[1], pos[2]}, {nrm[0], nrm[1], nrm[2]}, o.near, o.max_distance);
    REQUIRE(ray.valid);
    CHECK(ray.dir[2] > 0);
    CHECK(ray.origin[2] + ray.length * ray.dir[2] == Approx(-o.near).margin(1e-12));
  }
}

TEST_CASE("ssr: degenerate G-buffer entries give no hit and every output stays finite", "[ssr][raster]") {
  Rendered r = render(80, 60);
  // Corrupt a few covered pixels: zero normal, NaN position, a point in front of the near plane.
  double* pos = r.g.position.data<double>();
  double* nrm = r.g.normal.data<double>();
  std::vector<std::size_t> bad;
  for (std::size_t k = 0; k < std::size_t(r.W) * r.H && bad.size() < 3; ++k)
    if (r.g.mask.data<std::int32_t>()[k] && k % 97 == 0) bad.push_back(k);
  REQUIRE(bad.size() == 3);
  nrm[3 * bad[0]] = nrm[3 * bad[0] + 1] = nrm[3 * bad[0] + 2] = 0;
  pos[3 * bad[1]] = NAN;
  pos[3 * bad[2] + 2] = -0.01;
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda, SsrTracer::Reference}) {
    SsrOptions o = tracer_options(t);
    o.jitter = t == SsrTracer::Dda ? 0.7 : 0.0;
    o.stride = t == SsrTracer::Dda ? 3.0 : 1.0;
    const Outputs out = trace_all(r, o);
    INFO(name_of(t));
    for (const auto* v : {&out.hit, &out.xy, &out.dist, &out.point, &out.edge, &out.fade})
      for (double x : *v) REQUIRE(std::isfinite(x));
    for (std::size_t k : bad) CHECK(out.hit[k] == 0);
    CHECK(out.stats.hits > 100);
  }
}

TEST_CASE("ssr: a point that projects off the screen gives no hit, without marching from where it projects",
          "[ssr][raster]") {
  // An audit's finding: such an origin (a G-buffer whose position does not
  // belong to its pixel) made the DDA convert a pixel column of 7e12 to int
  // (undefined behaviour, the sanitizer job reports it) and the reference
  // march 1e8 pixels back to the screen in 0.05-pixel steps (a hang).
  const int W = 8, H = 6;
  std::vector<double> pos(3 * W * H, 0.0), nrm(3 * W * H, 0.0);
  std::vector<std::int32_t> mask(W * H, 0);
  const Vec3 far_points[] = {{1e12, 0, -1}, {-1e8, 0, -1}, {0, 1e12, -1}, {0.1, -1e8, -1}};
  for (int k = 0; k < 4; ++k) {
    for (int a = 0; a < 3; ++a) pos[3 * k + a] = far_points[k][a];
    // Normals that reflect each ray towards the screen along its long axis.
    nrm[3 * k + (k % 2 == 0 ? 0 : 1)] = k < 2 ? (k == 0 ? -1.0 : 1.0) : (k == 2 ? -1.0 : 1.0);
    mask[k] = 1;
  }
  // A covered floor to hit, everywhere else.
  for (int k = 4; k < W * H; ++k) pos[3 * k + 2] = -2, nrm[3 * k + 2] = 1, mask[k] = 1;
  const std::vector<double> m = perspective(1.0, double(W) / H, 0.1, 100.0, ClipSpace::OpenGL, DType::Float64).to_vector();
  std::vector<double> hit, xy;
  const SsrParams<double> p = params_of(W, H, m, pos, nrm, mask, hit, xy);
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda, SsrTracer::Reference}) {
    SsrOptions o = tracer_options(t);
    o.max_distance = 1e9;
    INFO(name_of(t));
    const SsrStats s = ssr_trace(p, o);
    CHECK(s.rays == W * H);
    for (int k = 0; k < 4; ++k) CHECK(hit[k] == 0);
    for (double x : xy) REQUIRE(std::isfinite(x));
  }
}

TEST_CASE("ssr: a float32 trace whose hit lies beyond the float range reports no hit and stays finite",
          "[ssr][raster]") {
  // An audit's finding: with max_distance 1e300 and a thick band, the ray
  // from the centre pixel hits its neighbour ~1e298 units away, and that hit
  // point and distance became Inf once stored as float.
  const int W = 3, H = 3;
  const double f = 1 / std::tan(0.5);
  const Vec3 R = {2.0 / 3.0 / f, 0, -1};  // vanishing point at the centre of pixel (2, 1)
  const double r = std::sqrt(R[0] * R[0] + R[2] * R[2]);
  // N = normalize(R / |R| - I) with I = (0, 0, -1) reflects I into R.
  const Vec3 n = {R[0] / r, 0, R[2] / r + 1};
  std::vector<float> pos(3 * W * H), nrm(3 * W * H);
  std::vector<std::int32_t> mask(W * H, 1);
  for (int k = 0; k < W * H; ++k) pos[3 * k + 2] = -1, nrm[3 * k + 2] = 1;
  for (int a = 0; a < 3; ++a) nrm[3 * 4 + a] = float(n[a]);  // pixel (1, 1): its point (0, 0, -1) is the centre
  SsrParams<float> p;
  p.width = W, p.height = H;
  const std::vector<double> m = perspective(1.0, 1.0, 0.1, 100.0, ClipSpace::OpenGL, DType::Float64).to_vector();
  std::copy(m.begin(), m.end(), p.projection.begin());
  p.position = pos.data(), p.normal = nrm.data(), p.mask = mask.data();
  std::vector<float> hit(W * H), xy(2 * W * H), dist(W * H), point(3 * W * H), edge(W * H), fade(W * H);
  p.hit = hit.data(), p.hit_xy = xy.data(), p.hit_distance = dist.data(), p.hit_position = point.data();
  p.edge_fade = edge.data(), p.distance_fade = fade.data();
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda, SsrTracer::Reference}) {
    SsrOptions o = tracer_options(t);
    o.max_distance = 1e300;
    o.thickness = 1e300;
    INFO(name_of(t));
    ssr_trace(p, o);
    for (const auto* v : {&hit, &xy, &dist, &point, &edge, &fade})
      for (float x : *v) REQUIRE(std::isfinite(x));
    // The view-space march's first sample there is ~1e298 away: no hit in float32.
    if (t == SsrTracer::ViewSpace) CHECK(hit[4] == 0);
  }
}

TEST_CASE("ssr: a back-face depth buffer removes the hits a thick band invents behind the spheres", "[ssr][raster]") {
  const Rendered r = render(160, 120, true, /*back_faces=*/true);
  auto false_hits = [&](bool use_back) {
    SsrOptions o = tracer_options(SsrTracer::Dda);
    o.thickness = 3.0;
    Rendered copy = r;
    if (!use_back) copy.g.back_z = Tensor(), copy.g.back_mask = Tensor();
    const Outputs out = trace_all(copy, o);
    int invented = 0;
    for (int j = 0; j < r.H; ++j)
      for (int i = 0; i < r.W; ++i) {
        const std::int32_t id = r.id(i, j);
        if (id == 0 || id > r.floor_tris || !out.hit[std::size_t(j) * r.W + i]) continue;
        invented += !analytic_hit(r, i, j, o.max_distance).hit;
      }
    return invented;
  };
  const int without = false_hits(false), with = false_hits(true);
  INFO("hits with no geometry on the ray: thick band " << without << ", with back faces " << with);
  CHECK(without > 50);
  CHECK(with * 10 < without);
}

TEST_CASE("ssr: the DDA with stride, jitter and binary search still lands within a few pixels of the reference",
          "[ssr][raster]") {
  const Rendered r = render(160, 120);
  const Outputs ref = trace_all(r, tracer_options(SsrTracer::Reference));
  SsrOptions o = tracer_options(SsrTracer::Dda);
  o.stride = 4, o.jitter = 1, o.binary_steps = 6, o.stride_z_cutoff = 100;
  const Outputs out = trace_all(r, o);
  int both = 0, close = 0;
  for (std::size_t k = 0; k < out.hit.size(); ++k)
    if (ref.hit[k] && out.hit[k]) {
      ++both;
      close += std::hypot(out.xy[2 * k] - ref.xy[2 * k], out.xy[2 * k + 1] - ref.xy[2 * k + 1]) <= 1.5;
    }
  INFO("both " << both << ", within 1.5 px " << close << ", samples " << out.stats.samples << " vs reference "
               << ref.stats.samples);
  CHECK(both > 500);
  CHECK(close >= both * 0.95);
  CHECK(out.stats.samples * 4 < ref.stats.samples);
}

TEST_CASE("ssr: traces are bit-identical for one and two threads", "[ssr][raster]") {
  const Rendered r = render(96, 72);
  for (SsrTracer t : {SsrTracer::ViewSpace, SsrTracer::Dda}) {
    SsrOptions o = tracer_options(t);
    o.jitter = t == SsrTracer::Dda ? 1.0 : 0.0;
    gr::set_num_threads(1);
    const Outputs a = trace_all(r, o);
    gr::set_num_threads(2);
    const Outputs b = trace_all(r, o);
    gr::set_num_threads(0);
    CHECK(a.hit == b.hit);
    CHECK(a.xy == b.xy);
    CHECK(a.point == b.point);
    CHECK(a.stats.samples == b.stats.samples);
  }
}

TEST_CASE("ssr: fades follow the article's formulas", "[ssr][raster]") {
  SsrOptions o;
  o.edge_form = EdgeFade::Circular;
  o.edge_exponent = 2;
  CHECK(ssr_edge_fade(50, 25, 100, 50, o) == Approx(1.0));
  CHECK(ssr_edge_fade(75, 25, 100, 50, o) == Approx(0.75));  // r = 0.5
  CHECK(ssr_edge_fade(100, 25, 100, 50, o) == Approx(0.0));
  CHECK(ssr_edge_fade(0, 0, 100, 50, o) == 0.0);              // saturated below 0
  o.edge_form = EdgeFade::Vignette;
  o.edge_distance = 16, o.edge_exponent = 0.5;
  CHECK(ssr_edge_fade(50, 25, 100, 50, o) == Approx(1.0));    // 16/16 = 1
  CHECK(ssr_edge_fade(10, 25, 100, 50, o) == Approx(std::sqrt(16 * 0.09 * 0.25)));
  o.fade_distance = 4, o.fade_exponent = 2;
  CHECK(ssr_distance_fade(2, o) == Approx(0.75));
  CHECK(ssr_distance_fade(5, o) == 0.0);
}

TEST_CASE("ssr: bad sizes and options throw ValueError naming them", "[ssr][raster]") {
  const Rendered r = render(32, 24);
  SsrParams<double> p = params_of(r);
  SsrOptions o;
  o.max_steps = 0;
  CHECK_THROWS_AS(ssr_trace(p, o), ValueError);
  o = SsrOptions();
  o.stride = 0.5;
  CHECK_THROWS_WITH(ssr_trace(p, o), Catch::Contains("stride"));
  o = SsrOptions();
  o.near = 0;
  CHECK_THROWS_WITH(ssr_trace(p, o), Catch::Contains("near"));
  p.width = 0;
  CHECK_THROWS_AS(ssr_trace(p, SsrOptions()), ValueError);
}
