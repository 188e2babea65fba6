// Transformation matrices as compositions of differentiable ops: each builds
// its 16 entries as rank-0 tensors and stacks them, so no hand-written adjoint
// is needed here.
#include "ops/render/transforms.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ops/tensor/elementwise.h"
#include "ops/tensor/linalg.h"
#include "ops/tensor/shape_ops.h"
#include "ops/tensor/vector.h"
#include "ops/tensor/broadcast.h"

namespace gr {
namespace {

// Row-major 4 x 4 matrix from 16 rank-0 tensors.
Tensor matrix4(const std::vector<Tensor>& entries) { return reshape(stack(entries, 0), {4, 4}); }

// Element i of a vector as a rank-0 tensor (differentiable).
Tensor component(const Tensor& v, std::int64_t i) { return reshape(slice(v, -1, i, i + 1), {}); }

// A one-element tensor as rank 0; throws naming the argument otherwise.
Tensor scalar_arg(const Tensor& t, const char* op, const char* name) {
  detail::check_float(t, op, name);
  if (t.numel() != 1)
    throw ShapeError(std::string(op) + ": argument '" + name + "' must have one element, got " + t.describe());
  return reshape(t, {});
}

void check_vector(const Tensor& t, std::int64_t n, const char* op, const char* name) {
  detail::check_float(t, op, name);
  detail::check_shape(t, {n}, op, name);
}

Tensor constant(double v, DType dtype) { return Tensor::scalar(v, dtype); }

// 3 x 3 rotation block r (rows) and translation t (3 x 1) -> 4 x 4.
Tensor affine(const Tensor& r, const Tensor& t) {
  const DType dt = r.dtype();
  Tensor bottom = Tensor::from_values({0, 0, 0, 1}, {1, 4}, dt);
  return concat({concat({r, t}, 1), bottom}, 0);
}

// ---- look_at's camera frame, free of absolute thresholds ----
// Every direction is divided by its largest |component| (a constant read from
// the values) before normalize: |v|^2 can then neither underflow (a camera
// 1e-13 from its target) nor overflow, and normalize's eps never applies.
// Since normalize(v) = normalize(v / c) for any c > 0, the gradient is that of
// normalize(v) itself. What has no direction is refused, relative to the
// scale of the inputs and to the dtype's resolution.

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

std::string vector_text(const std::vector<double>& v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.17g, %.17g, %.17g)", v[0], v[1], v[2]);
  return text;
}

// v / max|v_i|, normalized; v must have a non-zero finite component.
Tensor unit(const Tensor& v, const char* op) {
  const double m = max_abs(v.to_vector());
  if (!(m > 0) || !std::isfinite(m)) throw ValueError(std::string(op) + ": internal error: no direction to normalize");
  return normalize(v / m);
}

struct CameraAxes {
  Tensor forward;  // unit (target - eye)
  Tensor up;       // up / max|up_i|
};

CameraAxes camera_axes(const Tensor& eye, const Tensor& target, const Tensor& up, const char* op) {
  check_vector(eye, 3, op, "eye");
  check_vector(target, 3, op, "target");
  check_vector(up, 3, op, "up");
  const std::string name = op;
  const std::vector<double> e = eye.to_vector(), t = target.to_vector(), u = up.to_vector();
  for (const auto& [v, arg] : {std::pair{&e, "eye"}, std::pair{&t, "target"}, std::pair{&u, "up"}})
    for (double x : *v)
      if (!std::isfinite(x)) throw ValueError(name + ": " + arg + " " + vector_text(*v) + " is not finite");
  const Tensor d = target - eye;  // in the inputs' dtype, as the matrix uses it
  const std::vector<double> dv = d.to_vector();
  const double md = max_abs(dv), scale = std::max(max_abs(e), max_abs(t));
  const double eps = d.dtype() == DType::Float32 ? 1.1920928955078125e-7 : 2.220446049250313e-16;
  if (!std::isfinite(md))
    throw ValueError(name + ": eye " + vector_text(e) + " and target " + vector_text(t) +
                     " are too far apart: target - eye overflows");
  if (md == 0)
    throw ValueError(name + ": eye and target coincide at " + vector_text(e) + ": the view direction is undefined");
  if (md <= 8 * eps * scale)
    throw ValueError(name + ": eye " + vector_text(e) + " and target " + vector_text(t) +
                     " differ only by the rounding of their coordinates: the view direction is lost");
  const double mu = max_abs(u);
  if (mu == 0) throw ValueError(name + ": up is the zero vector");
  // sin(angle between up and the view direction), on unit vectors in double.
  auto normalized = [](std::vector<double> v) {
    const double m = max_abs(v);
    for (double& x : v) x /= m;
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (double& x : v) x /= n;
    return v;
  };
  const std::vector<double> f = normalized(dv), w = normalized(u);
  const double c[3] = {f[1] * w[2] - f[2] * w[1], f[2] * w[0] - f[0] * w[2], f[0] * w[1] - f[1] * w[0]};
  if (std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) <= 1000 * eps)
    throw ValueError(name + ": up " + vector_text(u) + " is parallel to the view direction target - eye " +
                     vector_text(dv) + ": the camera's roll is undefined");
  return {normalize(d / md), up / mu};
}

}  // namespace

Tensor identity4(DType dtype) {
  return Tensor::from_values({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}, {4, 4}, dtype);
}

Tensor scale(const Tensor& s) {
  check_vector(s, 3, "scale", "s");
  const DType dt = s.dtype();
  Tensor o = constant(0, dt), i = constant(1, dt);
  return matrix4({component(s, 0), o, o, o,  //
                  o, component(s, 1), o, o,  //
                  o, o, component(s, 2), o,  //
                  o, o, o, i});
}

Tensor translate(const Tensor& t) {
  check_vector(t, 3, "translate", "t");
  const DType dt = t.dtype();
  Tensor o = constant(0, dt), i = constant(1, dt);
  return matrix4({i, o, o, component(t, 0),  //
                  o, i, o, component(t, 1),  //
                  o, o, i, component(t, 2),  //
                  o, o, o, i});
}

Tensor rotate_x(const Tensor& angle) {
  Tensor a = scalar_arg(angle, "rotate_x", "angle");
  Tensor c = cos(a), s = sin(a), o = constant(0, a.dtype()), i = constant(1, a.dtype());
  return matrix4({i, o, o, o, o, c, -s, o, o, s, c, o, o, o, o, i});
}

Tensor rotate_y(const Tensor& angle) {
  Tensor a = scalar_arg(angle, "rotate_y", "angle");
  Tensor c = cos(a), s = sin(a), o = constant(0, a.dtype()), i = constant(1, a.dtype());
  return matrix4({c, o, s, o, o, i, o, o, -s, o, c, o, o, o, o, i});
}

Tensor rotate_z(const Tensor& angle) {
  Tensor a = scalar_arg(angle, "rotate_z", "angle");
  Tensor c = cos(a), s = sin(a), o = constant(0, a.dtype()), i = constant(1, a.dtype());
  return matrix4({c, -s, o, o, s, c, o, o, o, o, i, o, o, o, o, i});
}

Tensor rotation_axis_angle(const Tensor& axis, const Tensor& angle) {
  check_vector(axis, 3, "rotation_axis_angle", "axis");
  Tensor a = scalar_arg(angle, "rotation_axis_angle", "angle");
  detail::check_same_dtype(axis, a, "rotation_axis_angle", "axis", "angle");
  Tensor k = normalize(axis);
  Tensor x = component(k, 0), y = component(k, 1), z = component(k, 2);
  Tensor c = cos(a), s = sin(a), t = 1.0 - c;
  Tensor o = constant(0, a.dtype()), i = constant(1, a.dtype());
  return matrix4({c + t * x * x, t * x * y - s * z, t * x * z + s * y, o,  //
                  t * x * y + s * z, c + t * y * y, t * y * z - s * x, o,  //
                  t * x * z - s * y, t * y * z + s * x, c + t * z * z, o,  //
                  o, o, o, i});
}

Tensor rotation_quaternion(const Tensor& q) {
  check_vector(q, 4, "rotation_quaternion", "q");
  Tensor u = normalize(q);
  Tensor w = component(u, 0), x = component(u, 1), y = component(u, 2), z = component(u, 3);
  Tensor o = constant(0, q.dtype()), i = constant(1, q.dtype());
  return matrix4({1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y), o,  //
                  2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x), o,  //
                  2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y), o,  //
                  o, o, o, i});
}

Tensor look_at(const Tensor& eye, const Tensor& target, const Tensor& up) {
  const CameraAxes a = camera_axes(eye, target, up, "look_at");
  Tensor s = unit(cross(a.forward, a.up), "look_at");
  Tensor u = cross(s, a.forward);
  Tensor r = stack({s, u, -a.forward}, 0);             // rows: camera axes in world space
  Tensor t = -matmul(r, reshape(eye, {3, 1}));        // -R eye
  return affine(r, t);
}

Tensor look_at_lh(const Tensor& eye, const Tensor& target, const Tensor& up) {
  const CameraAxes a = camera_axes(eye, target, up, "look_at_lh");
  Tensor x = unit(cross(a.up, a.forward), "look_at_lh");
  Tensor y = cross(a.forward, x);
  Tensor r = stack({x, y, a.forward}, 0);
  Tensor t = -matmul(r, reshape(eye, {3, 1}));
  return affine(r, t);
}

Tensor perspective(const Tensor& fov_y, double aspect, double near, double far, ClipSpace convention) {
  Tensor fov = scalar_arg(fov_y, "perspective", "fov_y");
  if (!(aspect > 0) || !std::isfinite(aspect)) throw ValueError("perspective: aspect must be positive, got " + std::to_string(aspect));
  if (!(near > 0) || !(far > near) || !std::isfinite(far))
    throw ValueError("perspective: need 0 < near < far, got near " + std::to_string(near) + ", far " + std::to_string(far));
  const double fv = fov.item();
  if (!(fv > 0 && fv < M_PI)) throw ValueError("perspective: fov_y must lie in (0, pi) radians, got " + std::to_string(fv));
  const DType dt = fov.dtype();
  Tensor f = cos(fov * 0.5) / sin(fov * 0.5);  // cot(fov / 2)
  Tensor o = constant(0, dt);
  if (convention == ClipSpace::OpenGL) {
    return matrix4({f / aspect, o, o, o,  //
                    o, f, o, o,           //
                    o, o, constant((far + near) / (near - far), dt), constant(2 * far * near / (near - far), dt),  //
                    o, o, constant(-1, dt), o});
  }
  return matrix4({f / aspect, o, o, o,  //
                  o, f, o, o,           //
                  o, o, constant(far / (far - near), dt), constant(-far * near / (far - near), dt),  //
                  o, o, constant(1, dt), o});
}

Tensor perspective(double fov_y, double aspect, double near, double far, ClipSpace convention, DType dtype) {
  return perspective(Tensor::scalar(fov_y, dtype), aspect, near, far, convention);
}

Tensor orthographic(double left, double right, double bottom, double top, double near, double far,
                    ClipSpace convention, DType dtype) {
  // Each pair of bounds must be finite and distinct (a NaN fails the test too).
  auto check_extent = [](double lo, double hi, const char* lo_name, const char* hi_name) {
    if (!std::isfinite(lo) || !std::isfinite(hi) || lo == hi)
      throw ValueError(std::string("orthographic: ") + lo_name + " and " + hi_name +
                       " must be finite and differ (the box needs non-zero extent), got " + lo_name + " " +
                       std::to_string(lo) + ", " + hi_name + " " + std::to_string(hi));
  };
  check_extent(left, right, "left", "right");
  check_extent(bottom, top, "bottom", "top");
  check_extent(near, far, "near", "far");
  const double sx = 2 / (right - left), tx = -(right + left) / (right - left);
  const double sy = 2 / (top - bottom), ty = -(top + bottom) / (top - bottom);
  // OpenGL maps view z = -near -> -1 and -far -> 1; Direct3D maps z = near -> 0, far -> 1.
  const double sz = convention == ClipSpace::OpenGL ? -2 / (far - near) : 1 / (far - near);
  const double tz = convention == ClipSpace::OpenGL ? -(far + near) / (far - near) : -near / (far - near);
  return Tensor::from_values({sx, 0, 0, tx, 0, sy, 0, ty, 0, 0, sz, tz, 0, 0, 0, 1}, {4, 4}, dtype);
}

// ---- OpenGL column-major float[16] ----

namespace {

template <class S>
Tensor from_column_major(const S* m, DType dtype) {
  if (m == nullptr) throw ValueError("mat4_from_column_major: argument 'm' is a null pointer");
  std::vector<double> rows(16);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      const double x = m[4 * c + r];
      if (!std::isfinite(x))
        throw ValueError("mat4_from_column_major: element " + std::to_string(4 * c + r) + " (row " + std::to_string(r) +
                         ", column " + std::to_string(c) + ") is " + std::to_string(x));
      rows[4 * r + c] = x;
    }
  return Tensor::from_values(rows, {4, 4}, dtype);
}

template <class D>
std::array<D, 16> to_column_major(const Tensor& matrix) {
  detail::check_float(matrix, "mat4_to_column_major", "matrix");
  if (matrix.shape() != Shape{4, 4})
    throw ShapeError("mat4_to_column_major: argument 'matrix' must have shape [4, 4], got " + matrix.describe());
  const std::vector<double> rows = matrix.to_vector();
  std::array<D, 16> m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[4 * c + r] = static_cast<D>(rows[4 * r + c]);
  return m;
}

}  // namespace

Tensor mat4_from_column_major(const float* m, DType dtype) { return from_column_major(m, dtype); }
Tensor mat4_from_column_major(const double* m, DType dtype) { return from_column_major(m, dtype); }
std::array<float, 16> mat4_to_column_major(const Tensor& matrix) { return to_column_major<float>(matrix); }
std::array<double, 16> mat4_to_column_major_f64(const Tensor& matrix) { return to_column_major<double>(matrix); }

}  // namespace gr
