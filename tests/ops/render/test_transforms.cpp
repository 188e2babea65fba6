// Tests of the 4 x 4 matrix builders in ops/render/transforms: finite-difference
// checks of every tensor parameter, known images of points under each matrix
// (right-hand rule, camera frames, both clip-space conventions, the vertex-shader
// notes' Direct3D projection), and the argument checks.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "ops/ops.h"
#include "test_support.h"

using namespace gr;
using gr::testing::all_finite;
using gr::testing::random_input;
using gr::testing::require_gradcheck;

namespace {
using Inputs = std::vector<Tensor>;
constexpr double kPi = 3.14159265358979323846;
constexpr double kTol = 1e-12;

Tensor vec(const std::vector<double>& v) {
  return Tensor::from_values(v, {static_cast<std::int64_t>(v.size())}, DType::Float64);
}
Tensor angle(double a) { return Tensor::from_values({a}, {1}, DType::Float64); }

// M applied to the homogeneous point (p, w): returns (x, y, z, w).
std::vector<double> apply_to(const Tensor& m, const std::vector<double>& p, double w = 1) {
  return transform_points(Tensor::from_values({p[0], p[1], p[2], w}, {1, 4}, m.dtype()), m).to_vector();
}
// M applied to the point p, divided by w: (x/w, y/w, z/w).
std::vector<double> project(const Tensor& m, const std::vector<double>& p) {
  std::vector<double> c = apply_to(m, p);
  return {c[0] / c[3], c[1] / c[3], c[2] / c[3]};
}

void check_vec(const std::vector<double>& got, const std::vector<double>& want, double tol = kTol) {
  REQUIRE(got.size() >= want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    INFO("component " << i);
    CHECK(got[i] == Approx(want[i]).margin(tol));
  }
}

void check_same_matrix(const Tensor& a, const Tensor& b, double tol = kTol) {
  REQUIRE(a.shape() == Shape{4, 4});
  REQUIRE(b.shape() == Shape{4, 4});
  check_vec(a.to_vector(), b.to_vector(), tol);
}

// The upper-left 3 x 3 block is orthonormal with determinant 1, and the
// matrix is affine (last row 0 0 0 1).
void check_rotation_block(const Tensor& m) {
  REQUIRE(m.shape() == Shape{4, 4});
  auto r = [&](int i, int j) { return m.at({i, j}); };
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d += r(k, i) * r(k, j);
      INFO("column dot " << i << ", " << j);
      CHECK(d == Approx(i == j ? 1.0 : 0.0).margin(1e-12));
    }
  const double det = r(0, 0) * (r(1, 1) * r(2, 2) - r(1, 2) * r(2, 1)) -
                     r(0, 1) * (r(1, 0) * r(2, 2) - r(1, 2) * r(2, 0)) +
                     r(0, 2) * (r(1, 0) * r(2, 1) - r(1, 1) * r(2, 0));
  CHECK(det == Approx(1.0).margin(1e-12));
  check_vec({r(3, 0), r(3, 1), r(3, 2), r(3, 3)}, {0, 0, 0, 1});
}

double norm3(const std::vector<double>& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }
}  // namespace

// ---------------------------------------------------------------------------
// Gradient checks

TEST_CASE("scale and translate: gradients w.r.t. their vectors match finite differences",
          "[ops][transforms][gradcheck]") {
  require_gradcheck("scale", [](const Inputs& in) { return scale(in[0]); }, {random_input({3}, -2, 2, 101)});
  require_gradcheck("translate", [](const Inputs& in) { return translate(in[0]); }, {random_input({3}, -2, 2, 102)});
}

TEST_CASE("rotate_x, rotate_y, rotate_z: gradients w.r.t. the angle match finite differences",
          "[ops][transforms][gradcheck]") {
  require_gradcheck("rotate_x", [](const Inputs& in) { return rotate_x(in[0]); }, {random_input({1}, -3, 3, 103)});
  require_gradcheck("rotate_y", [](const Inputs& in) { return rotate_y(in[0]); }, {random_input({1}, -3, 3, 104)});
  require_gradcheck("rotate_z", [](const Inputs& in) { return rotate_z(in[0]); }, {random_input({1}, -3, 3, 105)});
  // A rank-0 angle works as well.
  require_gradcheck("rotate_z rank-0", [](const Inputs& in) { return rotate_z(in[0]); }, {random_input({}, -3, 3, 106)});
}

TEST_CASE("rotation_axis_angle: gradients w.r.t. axis and angle match finite differences",
          "[ops][transforms][gradcheck]") {
  Tensor axis = random_input({3}, 0.3, 1.5, 107);  // unnormalized: the normalize adjoint is exercised
  Tensor a = random_input({1}, -3, 3, 108);
  require_gradcheck("rotation_axis_angle", [](const Inputs& in) { return rotation_axis_angle(in[0], in[1]); }, {axis, a});
}

TEST_CASE("rotation_quaternion: gradients w.r.t. an unnormalized quaternion match finite differences",
          "[ops][transforms][gradcheck]") {
  require_gradcheck("rotation_quaternion", [](const Inputs& in) { return rotation_quaternion(in[0]); },
                    {random_input({4}, -1.5, 1.5, 109)});
}

TEST_CASE("look_at and look_at_lh: gradients w.r.t. eye, target and up match finite differences",
          "[ops][transforms][gradcheck]") {
  Tensor eye = vec({2.0, 1.5, 3.0}) + random_input({3}, -0.3, 0.3, 110).detach();
  Tensor target = random_input({3}, -0.5, 0.5, 111).detach();
  Tensor up = vec({0.1, 1.0, -0.2}) + random_input({3}, -0.2, 0.2, 112).detach();
  eye.set_requires_grad();
  target.set_requires_grad();
  up.set_requires_grad();
  require_gradcheck("look_at", [](const Inputs& in) { return look_at(in[0], in[1], in[2]); }, {eye, target, up});
  require_gradcheck("look_at_lh", [](const Inputs& in) { return look_at_lh(in[0], in[1], in[2]); }, {eye, target, up});
}

TEST_CASE("perspective: gradient w.r.t. fov_y matches finite differences in both conventions",
          "[ops][transforms][gradcheck]") {
  Tensor fov = random_input({1}, 0.4, 2.0, 113);
  require_gradcheck("perspective OpenGL",
                    [](const Inputs& in) { return perspective(in[0], 1.6, 0.1, 50.0, ClipSpace::OpenGL); }, {fov});
  require_gradcheck("perspective Direct3D",
                    [](const Inputs& in) { return perspective(in[0], 1.6, 0.1, 50.0, ClipSpace::Direct3D); }, {fov});
}

TEST_CASE("perspective: the gradient of f = cot(fov_y / 2) is -1 / (2 sin^2(fov_y / 2))", "[ops][transforms]") {
  const double fv = 1.1, aspect = 2.0;
  Tensor fov = angle(fv).set_requires_grad();
  // Weight m11 = f by 1 and m00 = f / aspect by 1.
  Tensor w = Tensor::from_values({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}, {4, 4}, DType::Float64);
  backward(sum(perspective(fov, aspect, 0.5, 10.0) * w));
  const double s = std::sin(fv / 2);
  CHECK(fov.grad().item() == Approx(-(1 + 1 / aspect) / (2 * s * s)).epsilon(1e-12));
}

TEST_CASE("perspective * look_at * model: gradients of transformed points w.r.t. points, eye, fov and angle match "
          "finite differences",
          "[ops][transforms][gradcheck]") {
  Tensor points = random_input({5, 3}, -1, 1, 114);
  Tensor eye = (vec({1.0, 2.0, 4.0}) + random_input({3}, -0.3, 0.3, 115).detach()).set_requires_grad();
  Tensor fov = random_input({1}, 0.7, 1.2, 116);
  Tensor theta = random_input({1}, -1, 1, 117);
  const Tensor target = vec({0, 0, 0}), up = vec({0, 1, 0});
  for (ClipSpace cs : {ClipSpace::OpenGL, ClipSpace::Direct3D}) {
    auto chain = [&, cs](const Inputs& in) {
      Tensor view = cs == ClipSpace::OpenGL ? look_at(in[1], target, up) : look_at_lh(in[1], target, up);
      Tensor mvp = matmul(perspective(in[2], 1.25, 0.5, 20.0, cs), matmul(view, rotate_y(in[3])));
      return transform_points(in[0], mvp);
    };
    require_gradcheck(cs == ClipSpace::OpenGL ? "mvp chain OpenGL" : "mvp chain Direct3D", chain,
                      {points, eye, fov, theta});
  }
}

// ---------------------------------------------------------------------------
// Known values

TEST_CASE("rotate_x, rotate_y, rotate_z by pi/2 follow the right-hand rule", "[ops][transforms]") {
  // rotate_z: +x -> +y, +y -> -x.
  Tensor rz = rotate_z(angle(kPi / 2));
  check_vec(apply_to(rz, {1, 0, 0}), {0, 1, 0, 1});
  check_vec(apply_to(rz, {0, 1, 0}), {-1, 0, 0, 1});
  check_vec(apply_to(rz, {0, 0, 1}), {0, 0, 1, 1});
  // rotate_x: +y -> +z, +z -> -y.
  Tensor rx = rotate_x(angle(kPi / 2));
  check_vec(apply_to(rx, {0, 1, 0}), {0, 0, 1, 1});
  check_vec(apply_to(rx, {0, 0, 1}), {0, -1, 0, 1});
  check_vec(apply_to(rx, {1, 0, 0}), {1, 0, 0, 1});
  // rotate_y: +z -> +x, +x -> -z.
  Tensor ry = rotate_y(angle(kPi / 2));
  check_vec(apply_to(ry, {0, 0, 1}), {1, 0, 0, 1});
  check_vec(apply_to(ry, {1, 0, 0}), {0, 0, -1, 1});
  check_vec(apply_to(ry, {0, 1, 0}), {0, 1, 0, 1});
}

TEST_CASE("scale and translate: diagonal and last-column matrices as in the vertex-shader notes", "[ops][transforms]") {
  check_vec(scale(vec({2, -3, 0.5})).to_vector(), {2, 0, 0, 0, 0, -3, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 1});
  check_vec(translate(vec({1, -2, 3})).to_vector(), {1, 0, 0, 1, 0, 1, 0, -2, 0, 0, 1, 3, 0, 0, 0, 1});
  check_vec(apply_to(translate(vec({1, -2, 3})), {1, 1, 1}), {2, -1, 4, 1});
  // Directions (w = 0) are not translated.
  check_vec(apply_to(translate(vec({1, -2, 3})), {1, 1, 1}, 0), {1, 1, 1, 0});
  check_same_matrix(identity4(DType::Float64), scale(vec({1, 1, 1})));
  CHECK(identity4().dtype() == DType::Float32);
  CHECK(scale(vec({1, 2, 3})).dtype() == DType::Float64);
}

TEST_CASE("rotation_axis_angle about z equals rotate_z, and about x and y the other axis rotations",
          "[ops][transforms]") {
  for (double t : {-2.5, -0.3, 0.0, 0.7, kPi / 2, 3.0}) {
    INFO("angle " << t);
    check_same_matrix(rotation_axis_angle(vec({0, 0, 1}), angle(t)), rotate_z(angle(t)));
    check_same_matrix(rotation_axis_angle(vec({0, 0, 2.5}), angle(t)), rotate_z(angle(t)));  // axis is normalized
    check_same_matrix(rotation_axis_angle(vec({1, 0, 0}), angle(t)), rotate_x(angle(t)));
    check_same_matrix(rotation_axis_angle(vec({0, 1, 0}), angle(t)), rotate_y(angle(t)));
  }
  // Rotating about an axis leaves the axis fixed.
  const std::vector<double> k = {1, -2, 0.5};
  check_vec(apply_to(rotation_axis_angle(vec(k), angle(1.3)), k), {1, -2, 0.5, 1});
}

TEST_CASE("rotation_quaternion of angle t about axis k equals rotation_axis_angle(k, t)", "[ops][transforms]") {
  const std::vector<std::vector<double>> axes = {{0, 0, 1}, {1, 0, 0}, {0.3, -0.8, 0.52}, {-1, 2, 3}};
  for (const auto& raw : axes) {
    const double n = norm3(raw);
    const std::vector<double> k = {raw[0] / n, raw[1] / n, raw[2] / n};
    for (double t : {-2.0, 0.4, 1.9, 3.1}) {
      INFO("axis (" << k[0] << ", " << k[1] << ", " << k[2] << "), angle " << t);
      const double c = std::cos(t / 2), s = std::sin(t / 2);
      Tensor q = vec({c, s * k[0], s * k[1], s * k[2]});
      check_same_matrix(rotation_quaternion(q), rotation_axis_angle(vec(raw), angle(t)));
      // q and a positive multiple of it (and -q) describe the same rotation.
      check_same_matrix(rotation_quaternion(q * 3.7), rotation_axis_angle(vec(raw), angle(t)));
      check_same_matrix(rotation_quaternion(-q), rotation_axis_angle(vec(raw), angle(t)));
    }
  }
  check_same_matrix(rotation_quaternion(vec({1, 0, 0, 0})), identity4(DType::Float64));
}

TEST_CASE("rotation matrices are orthonormal with determinant 1", "[ops][transforms]") {
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    INFO("seed " << seed);
    Tensor a = Tensor::uniform({1}, -4, 4, 200 + seed, DType::Float64);
    check_rotation_block(rotate_x(a));
    check_rotation_block(rotate_y(a));
    check_rotation_block(rotate_z(a));
    check_rotation_block(rotation_axis_angle(Tensor::uniform({3}, -2, 2, 210 + seed, DType::Float64), a));
    check_rotation_block(rotation_quaternion(Tensor::uniform({4}, -2, 2, 220 + seed, DType::Float64)));
  }
}

TEST_CASE("look_at maps eye to the origin, target onto -z at its distance, and up into the upper y-z half-plane",
          "[ops][transforms]") {
  const std::vector<double> eye = {2, 1.5, 3}, target = {-0.5, 0.2, 0.4}, up = {0.2, 1, -0.1};
  Tensor v = look_at(vec(eye), vec(target), vec(up));
  check_rotation_block(v);
  check_vec(apply_to(v, eye), {0, 0, 0, 1});
  const double d = norm3({target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]});
  check_vec(apply_to(v, target), {0, 0, -d, 1});
  std::vector<double> u = apply_to(v, up, 0);  // a direction: rotation only
  CHECK(u[0] == Approx(0).margin(kTol));
  CHECK(u[1] > 0);
  CHECK(norm3(u) == Approx(norm3(up)).epsilon(1e-12));
  CHECK(all_finite(v));
  // The default OpenGL camera (at the origin looking down -z, y up) is the identity.
  check_same_matrix(look_at(vec({0, 0, 0}), vec({0, 0, -1}), vec({0, 1, 0})), identity4(DType::Float64));
  // Right-handed: from +z looking at the origin, world +x stays to the right (+x).
  Tensor v2 = look_at(vec({0, 0, 5}), vec({0, 0, 0}), vec({0, 1, 0}));
  check_vec(apply_to(v2, {1, 0, 0}), {1, 0, -5, 1});
}

TEST_CASE("look_at_lh maps eye to the origin, target onto +z at its distance, and up into the upper y-z half-plane",
          "[ops][transforms]") {
  const std::vector<double> eye = {2, 1.5, 3}, target = {-0.5, 0.2, 0.4}, up = {0.2, 1, -0.1};
  Tensor v = look_at_lh(vec(eye), vec(target), vec(up));
  check_rotation_block(v);
  check_vec(apply_to(v, eye), {0, 0, 0, 1});
  const double d = norm3({target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]});
  check_vec(apply_to(v, target), {0, 0, d, 1});
  std::vector<double> u = apply_to(v, up, 0);
  CHECK(u[0] == Approx(0).margin(kTol));
  CHECK(u[1] > 0);
  // The default Direct3D camera (at the origin looking down +z, y up) is the identity,
  // and from -z looking at the origin world +x is on the right.
  check_same_matrix(look_at_lh(vec({0, 0, 0}), vec({0, 0, 1}), vec({0, 1, 0})), identity4(DType::Float64));
  Tensor v2 = look_at_lh(vec({0, 0, -5}), vec({0, 0, 0}), vec({0, 1, 0}));
  check_vec(apply_to(v2, {1, 0, 0}), {1, 0, 5, 1});
}

TEST_CASE("perspective (OpenGL) maps the near and far planes to z_ndc -1 and 1 and the frustum edges to x, y = +-1",
          "[ops][transforms]") {
  const double fov = 0.9, aspect = 1.5, n = 0.25, f = 40;
  Tensor p = perspective(fov, aspect, n, f, ClipSpace::OpenGL, DType::Float64);
  CHECK(p.dtype() == DType::Float64);
  // w = -z: the camera looks down -z.
  CHECK(apply_to(p, {0.3, -0.2, -7})[3] == Approx(7));
  CHECK(project(p, {0, 0, -n})[2] == Approx(-1).margin(kTol));
  CHECK(project(p, {0, 0, -f})[2] == Approx(1).margin(1e-10));
  const double depth = 3.0, half_h = depth * std::tan(fov / 2), half_w = aspect * half_h;
  check_vec(project(p, {0, half_h, -depth}), {0, 1});
  check_vec(project(p, {0, -half_h, -depth}), {0, -1});
  check_vec(project(p, {half_w, 0, -depth}), {1, 0});
  check_vec(project(p, {-half_w, 0, -depth}), {-1, 0});
  // Depth increases monotonically from near to far.
  CHECK(project(p, {0, 0, -1})[2] < project(p, {0, 0, -2})[2]);
}

TEST_CASE("perspective (Direct3D) maps the near and far planes to z_ndc 0 and 1 with w = z", "[ops][transforms]") {
  const double fov = 1.2, aspect = 16.0 / 9.0, n = 0.5, f = 100;
  Tensor p = perspective(fov, aspect, n, f, ClipSpace::Direct3D, DType::Float64);
  CHECK(apply_to(p, {0.3, -0.2, 7})[3] == Approx(7));
  CHECK(project(p, {0, 0, n})[2] == Approx(0).margin(kTol));
  CHECK(project(p, {0, 0, f})[2] == Approx(1).margin(1e-10));
  const double depth = 5.0, half_h = depth * std::tan(fov / 2), half_w = aspect * half_h;
  check_vec(project(p, {0, half_h, depth}), {0, 1});
  check_vec(project(p, {0, -half_h, depth}), {0, -1});
  check_vec(project(p, {half_w, 0, depth}), {1, 0});
  check_vec(project(p, {-half_w, 0, depth}), {-1, 0});
  CHECK(project(p, {0, 0, 1})[2] < project(p, {0, 0, 2})[2]);
}

TEST_CASE("perspective (Direct3D) equals the vertex-shader notes' matrix for the equivalent horizontal fov and h/w "
          "aspect",
          "[ops][transforms]") {
  // The notes: diag(1 / tan(theta/2), 1 / (a tan(theta/2))) with theta the horizontal
  // fov and a = height / width; ours: diag(f / aspect, f), f = cot(fov_y / 2), aspect = width / height.
  for (double fov_y : {0.3, 1.0, 2.5}) {
    for (double aspect : {0.75, 1.0, 16.0 / 9.0}) {
      INFO("fov_y " << fov_y << ", aspect " << aspect);
      const double n = 0.1, f = 30;
      const double theta = 2 * std::atan(aspect * std::tan(fov_y / 2));  // horizontal fov
      const double a = 1 / aspect;                                        // height / width
      Tensor notes = Tensor::from_values({1 / std::tan(theta / 2), 0, 0, 0,            //
                                          0, 1 / (a * std::tan(theta / 2)), 0, 0,      //
                                          0, 0, f / (f - n), -f * n / (f - n),         //
                                          0, 0, 1, 0},
                                         {4, 4}, DType::Float64);
      check_same_matrix(perspective(fov_y, aspect, n, f, ClipSpace::Direct3D, DType::Float64), notes, 1e-12);
    }
  }
}

TEST_CASE("orthographic maps the corners of its box to the corners of the NDC cube in both conventions",
          "[ops][transforms]") {
  const double l = -2, r = 3, b = -1, t = 0.5, n = 0.5, f = 8;
  for (ClipSpace cs : {ClipSpace::OpenGL, ClipSpace::Direct3D}) {
    const bool gl = cs == ClipSpace::OpenGL;
    INFO((gl ? "OpenGL" : "Direct3D"));
    Tensor o = orthographic(l, r, b, t, n, f, cs, DType::Float64);
    for (int i = 0; i < 8; ++i) {
      const double x = i & 1 ? r : l, y = i & 2 ? t : b, d = i & 4 ? f : n;
      const double z = gl ? -d : d;  // distances along the viewing direction
      INFO("corner " << i);
      check_vec(apply_to(o, {x, y, z}), {i & 1 ? 1.0 : -1.0, i & 2 ? 1.0 : -1.0, i & 4 ? 1.0 : (gl ? -1.0 : 0.0), 1.0});
    }
    // The box centre goes to the NDC centre (z: 0 for OpenGL, 0.5 for Direct3D).
    check_vec(apply_to(o, {(l + r) / 2, (b + t) / 2, gl ? -(n + f) / 2 : (n + f) / 2}), {0, 0, gl ? 0.0 : 0.5, 1});
  }
  CHECK(orthographic(-1, 1, -1, 1, 1, 2).dtype() == DType::Float32);
}

// ---------------------------------------------------------------------------
// Errors

TEST_CASE("transform builders reject wrongly shaped parameters with a message naming the argument",
          "[ops][transforms]") {
  CHECK_THROWS_AS(translate(vec({1, 2, 3, 4})), ShapeError);
  CHECK_THROWS_WITH(translate(vec({1, 2, 3, 4})), Catch::Contains("'t'") && Catch::Contains("[3]"));
  CHECK_THROWS_WITH(scale(vec({1, 2})), Catch::Contains("'s'") && Catch::Contains("[3]"));
  CHECK_THROWS_WITH(scale(Tensor::ones({1, 3}, DType::Float64)), Catch::Contains("'s'"));
  CHECK_THROWS_AS(rotate_x(vec({1, 2})), ShapeError);
  CHECK_THROWS_WITH(rotate_x(vec({1, 2})), Catch::Contains("rotate_x") && Catch::Contains("'angle'"));
  CHECK_THROWS_WITH(rotate_y(vec({})), Catch::Contains("rotate_y") && Catch::Contains("'angle'"));
  CHECK_THROWS_WITH(rotate_z(Tensor::ones({2, 2}, DType::Float64)), Catch::Contains("'angle'"));
  CHECK_THROWS_WITH(rotation_axis_angle(vec({0, 1}), angle(1)), Catch::Contains("'axis'"));
  CHECK_THROWS_WITH(rotation_axis_angle(vec({0, 0, 1}), vec({1, 2})), Catch::Contains("'angle'"));
  CHECK_THROWS_AS(rotation_axis_angle(vec({0, 0, 1}), Tensor::scalar(1.0, DType::Float32)), DTypeError);
  CHECK_THROWS_WITH(rotation_quaternion(vec({1, 0, 0})), Catch::Contains("'q'") && Catch::Contains("[4]"));
  CHECK_THROWS_WITH(look_at(vec({1, 2}), vec({0, 0, 0}), vec({0, 1, 0})), Catch::Contains("'eye'"));
  CHECK_THROWS_WITH(look_at(vec({1, 2, 3}), vec({0, 0, 0, 0}), vec({0, 1, 0})), Catch::Contains("'target'"));
  CHECK_THROWS_WITH(look_at_lh(vec({1, 2, 3}), vec({0, 0, 0}), vec({1})), Catch::Contains("'up'"));
  CHECK_THROWS_WITH(perspective(vec({1, 1}), 1.0, 0.1, 10.0), Catch::Contains("'fov_y'"));
  // Integer tensors are not parameters.
  CHECK_THROWS_AS(translate(Tensor::zeros({3}, DType::Int32)), DTypeError);
  CHECK_THROWS_WITH(rotate_z(Tensor::zeros({1}, DType::Int32)), Catch::Contains("'angle'"));
}

TEST_CASE("perspective rejects fov outside (0, pi), near <= 0, far <= near and aspect <= 0, naming the argument",
          "[ops][transforms]") {
  for (double fov : {0.0, -0.5, kPi, 4.0, std::nan("")}) {
    INFO("fov_y " << fov);
    CHECK_THROWS_AS(perspective(fov, 1.0, 0.1, 10.0), ValueError);
    CHECK_THROWS_WITH(perspective(fov, 1.0, 0.1, 10.0), Catch::Contains("fov_y"));
    CHECK_THROWS_WITH(perspective(angle(fov), 1.0, 0.1, 10.0, ClipSpace::Direct3D), Catch::Contains("fov_y"));
  }
  for (double near : {0.0, -1.0}) {
    INFO("near " << near);
    CHECK_THROWS_AS(perspective(1.0, 1.0, near, 10.0), ValueError);
    CHECK_THROWS_WITH(perspective(1.0, 1.0, near, 10.0), Catch::Contains("near"));
  }
  for (double far : {0.1, 0.05, std::numeric_limits<double>::infinity()}) {
    INFO("far " << far);
    CHECK_THROWS_AS(perspective(1.0, 1.0, 0.1, far, ClipSpace::Direct3D), ValueError);
    CHECK_THROWS_WITH(perspective(1.0, 1.0, 0.1, far, ClipSpace::Direct3D), Catch::Contains("far"));
  }
  for (double aspect : {0.0, -1.5, std::nan("")}) {
    INFO("aspect " << aspect);
    CHECK_THROWS_AS(perspective(1.0, aspect, 0.1, 10.0), ValueError);
    CHECK_THROWS_WITH(perspective(1.0, aspect, 0.1, 10.0), Catch::Contains("aspect"));
  }
  CHECK_NOTHROW(perspective(kPi - 1e-6, 0.01, 1e-6, 1e6));
}

TEST_CASE("orthographic rejects a box of zero extent, naming the equal bounds", "[ops][transforms]") {
  CHECK_THROWS_AS(orthographic(1, 1, -1, 1, 0.1, 10), ValueError);
  CHECK_THROWS_WITH(orthographic(1, 1, -1, 1, 0.1, 10), Catch::Contains("left") && Catch::Contains("right"));
  CHECK_THROWS_WITH(orthographic(-1, 1, 2, 2, 0.1, 10), Catch::Contains("bottom") && Catch::Contains("top"));
  CHECK_THROWS_WITH(orthographic(-1, 1, -1, 1, 3, 3, ClipSpace::Direct3D),
                    Catch::Contains("near") && Catch::Contains("far"));
  CHECK_THROWS_WITH(orthographic(std::nan(""), 1, -1, 1, 0.1, 10), Catch::Contains("left"));
  // Mirrored boxes (left > right) are allowed: they flip the axis.
  CHECK_NOTHROW(orthographic(1, -1, -1, 1, 0.1, 10));
}

TEST_CASE("matrices round-trip through OpenGL's column-major float[16], translation at elements 12, 13, 14",
          "[ops][transforms][gl]") {
  // glTranslatef(2, 3, 4) as OpenGL stores it.
  const float gl[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 2, 3, 4, 1};
  const Tensor m = mat4_from_column_major(gl);
  CHECK(m.dtype() == DType::Float32);
  CHECK(m.to_vector() == translate(Tensor::from_values({2, 3, 4}, {3})).to_vector());
  const Tensor p = transform_points(Tensor::from_values({1, 1, 1}, {1, 3}), m);
  CHECK(p.to_vector() == std::vector<double>{3, 4, 5, 1});
  const std::array<float, 16> back = mat4_to_column_major(m);
  CHECK(std::vector<float>(back.begin(), back.end()) == std::vector<float>(gl, gl + 16));

  // A general matrix: element (r, c) at 4c + r, both ways, in float64 too.
  double d[16];
  for (int i = 0; i < 16; ++i) d[i] = i + 0.25;
  const Tensor md = mat4_from_column_major(d, DType::Float64);
  CHECK(md.at({1, 2}) == d[4 * 2 + 1]);
  CHECK(md.at({3, 0}) == d[3]);
  const std::array<double, 16> dback = mat4_to_column_major_f64(md);
  CHECK(std::vector<double>(dback.begin(), dback.end()) == std::vector<double>(d, d + 16));
}

TEST_CASE("OpenGL matrix conversion rejects null pointers, NaN elements and non-4x4 tensors",
          "[ops][transforms][gl][errors]") {
  float gl[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  gl[13] = std::nanf("");
  CHECK_THROWS_WITH(mat4_from_column_major(gl), Catch::Contains("element 13 (row 1, column 3)"));
  CHECK_THROWS_AS(mat4_from_column_major(static_cast<const float*>(nullptr)), ValueError);
  CHECK_THROWS_AS(mat4_to_column_major(Tensor::ones({3, 3})), ShapeError);
  CHECK_THROWS_AS(mat4_to_column_major(Tensor::ones({4, 4}, DType::Int32)), DTypeError);
}

// ---------------------------------------------------------------------------
// look_at at any representable scale (issue 30 item 10)

namespace {

// Rows of the rotation block: each of length 1 and orthogonal to the others to `tol`.
void check_orthonormal_rows(const Tensor& m, double tol) {
  const std::vector<double> v = m.to_vector();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double d = 0;
      for (int k = 0; k < 3; ++k) d += v[4 * i + k] * v[4 * j + k];
      INFO("row dot " << i << ", " << j);
      CHECK(std::abs(d - (i == j ? 1.0 : 0.0)) <= tol);
    }
}

}  // namespace

TEST_CASE("look_at and look_at_lh give the same orthonormal rotation at tiny and huge scales", "[ops][transforms]") {
  const std::vector<double> eye = {2, 1.5, 3}, target = {-0.5, 0.2, 0.4}, up = {0.2, 1, -0.1};
  auto scaled = [](const std::vector<double>& v, double s, DType dt) {
    return Tensor::from_values({v[0] * s, v[1] * s, v[2] * s}, {3}, dt);
  };
  for (auto camera : {look_at, look_at_lh}) {
    const std::vector<double> unit_scale =
        camera(scaled(eye, 1, DType::Float64), scaled(target, 1, DType::Float64), scaled(up, 1, DType::Float64))
            .to_vector();
    for (double s : {1e-13, 1e-30, 1e-150, 1e-300, 1e150, 1e300}) {
      CAPTURE(s);
      const Tensor m = camera(scaled(eye, s, DType::Float64), scaled(target, s, DType::Float64),
                              scaled(up, s < 1 ? s : 1, DType::Float64));
      check_orthonormal_rows(m, 1e-12);
      const std::vector<double> v = m.to_vector();
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) CHECK(v[4 * i + j] == Approx(unit_scale[4 * i + j]).margin(1e-12));
      for (int i = 0; i < 3; ++i) CHECK(v[4 * i + 3] == Approx(unit_scale[4 * i + 3] * s).epsilon(1e-12));  // -R eye
    }
    for (double s : {1e-13, 1e-30}) {  // float32: normal numbers down to 1e-38
      CAPTURE(s);
      check_orthonormal_rows(camera(scaled(eye, s, DType::Float32), scaled(target, s, DType::Float32),
                                    scaled(up, s, DType::Float32)),
                             1e-6);
    }
  }
  // A camera 1e-13 from its target, far from the origin: the target lands on -z at that distance.
  const Tensor v = look_at(vec({1, 1, 1 + 1e-13}), vec({1, 1, 1}), vec({0, 1, 0}));
  check_orthonormal_rows(v, 1e-12);
  const std::vector<double> p = apply_to(v, {1, 1, 1});
  CHECK(std::abs(p[0]) < 1e-25);
  CHECK(p[2] == Approx(-((1 + 1e-13) - 1)).epsilon(1e-12));
}

TEST_CASE("look_at refuses what has no camera frame, naming the problem", "[ops][transforms][bad_input]") {
  const double inf = std::numeric_limits<double>::infinity();
  for (auto camera : {look_at, look_at_lh}) {
    CHECK_THROWS_WITH(camera(vec({1e-20, 2e-20, 3e-20}), vec({1e-20, 2e-20, 3e-20}), vec({0, 1, 0})),
                      Catch::Contains("eye and target coincide"));
    CHECK_THROWS_WITH(camera(vec({0, 0, 5}), vec({0, 0, 0}), vec({0, 0, 1e-9})),
                      Catch::Contains("parallel to the view direction"));
    CHECK_THROWS_WITH(camera(vec({0, 0, 5}), vec({0, 0, 0}), vec({0, 0, 0})), Catch::Contains("up is the zero vector"));
    CHECK_THROWS_WITH(camera(vec({1, 0, 0}), vec({1 + 2.220446049250313e-16, 0, 0}), vec({0, 1, 0})),
                      Catch::Contains("rounding of their coordinates"));
    CHECK_THROWS_WITH(camera(vec({inf, 0, 0}), vec({0, 0, 0}), vec({0, 1, 0})), Catch::Contains("eye (inf"));
    CHECK_THROWS_WITH(camera(vec({1e308, 0, 0}), vec({-1e308, 0, 0}), vec({0, 1, 0})), Catch::Contains("overflows"));
    CHECK_THROWS_AS(camera(vec({0, 0, 0}), vec({0, 0, 0}), vec({0, 1, 0})), ValueError);
  }
}

TEST_CASE("look_at and look_at_lh: gradients match finite differences at scales 1e-6 and 1e-13",
          "[ops][transforms][gradcheck]") {
  for (double s : {1e-6, 1e-13}) {
    CAPTURE(s);
    Tensor eye = ((vec({2.0, 1.5, 3.0}) + random_input({3}, -0.3, 0.3, 120).detach()) * s).detach();
    Tensor target = (random_input({3}, -0.5, 0.5, 121).detach() * s).detach();
    Tensor up = (vec({0.1, 1.0, -0.2}) * s).detach();
    eye.set_requires_grad();
    target.set_requires_grad();
    up.set_requires_grad();
    GradcheckOptions o;
    o.eps = 1e-4 * s;   // steps relative to the inputs
    o.atol = 1e-7 / s;  // the rotation's derivatives scale as 1 / s
    require_gradcheck("look_at", [](const Inputs& in) { return look_at(in[0], in[1], in[2]); }, {eye, target, up}, o);
    require_gradcheck("look_at_lh", [](const Inputs& in) { return look_at_lh(in[0], in[1], in[2]); },
                      {eye, target, up}, o);
  }
}
