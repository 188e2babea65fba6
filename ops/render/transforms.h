// 4 x 4 transformation matrices built from tensor parameters with ordinary
// ops, so gradients reach angles, translations, quaternions, camera position
// and field of view for free.
//
// Convention: column vectors, p' = M p (apply with transform_points). Angles
// in radians. Every function returns a [4, 4] tensor of its parameters' dtype.
//
// Two clip-space conventions are offered:
//  - ClipSpace::OpenGL (default): right-handed view space looking down -z,
//    NDC z in [-1, 1]; use with look_at().
//  - ClipSpace::Direct3D: left-handed view space looking down +z, NDC z in
//    [0, 1] (the vertex-shader notes' projection); use with look_at_lh().
#pragma once

#include <array>

#include "autodiff/base/tensor.h"

namespace gr {

enum class ClipSpace { OpenGL, Direct3D };

Tensor identity4(DType dtype = DType::Float32);
// diag(s, 1); s: [3].
Tensor scale(const Tensor& s);
// Translation by t: [3].
Tensor translate(const Tensor& t);
// Rotations about the coordinate axes by a one-element angle tensor
// (right-hand rule: rotate_z(pi/2) maps +x to +y).
Tensor rotate_x(const Tensor& angle);
Tensor rotate_y(const Tensor& angle);
Tensor rotate_z(const Tensor& angle);
// Rodrigues: R = cos(t) I + sin(t) [k]x + (1 - cos(t)) k k^T with k = normalize(axis).
Tensor rotation_axis_angle(const Tensor& axis, const Tensor& angle);
// Rotation of the unit quaternion q / |q|, q = (w, x, y, z): [4].
Tensor rotation_quaternion(const Tensor& q);

// Right-handed view matrix (gluLookAt): the camera at `eye` looks at `target`
// down its -z axis with `up` roughly up. eye, target, up: [3]. Works at any
// representable scale (no absolute threshold: a camera 1e-13 from its target
// gets an orthonormal rotation). Throws ValueError, naming the problem, for a
// non-finite input, eye == target (or apart by less than a few roundings of
// their coordinates), up == 0, and up parallel to target - eye.
Tensor look_at(const Tensor& eye, const Tensor& target, const Tensor& up);
// Left-handed view matrix: looks down +z, x = normalize(up x z), y = z x x.
// Same scale handling and refusals as look_at.
Tensor look_at_lh(const Tensor& eye, const Tensor& target, const Tensor& up);

// Perspective projection with vertical field of view fov_y (one-element
// tensor, radians), aspect = width / height, near > 0, far > near.
//  OpenGL:   x' = x f / aspect, y' = y f, z' = ((far+near) z + 2 far near) / (near - far), w = -z
//  Direct3D: x' = x f / aspect, y' = y f, z' = far (z - near) / (far - near),       w =  z
// with f = 1 / tan(fov_y / 2). (The vertex-shader notes write the Direct3D form
// with their angle as the horizontal field of view and aspect = height / width.)
Tensor perspective(const Tensor& fov_y, double aspect, double near, double far,
                   ClipSpace convention = ClipSpace::OpenGL);
Tensor perspective(double fov_y, double aspect, double near, double far,
                   ClipSpace convention = ClipSpace::OpenGL, DType dtype = DType::Float32);
// Orthographic projection of the box [left, right] x [bottom, top] x [near, far]
// (distances along the viewing direction) to NDC.
Tensor orthographic(double left, double right, double bottom, double top, double near, double far,
                    ClipSpace convention = ClipSpace::OpenGL, DType dtype = DType::Float32);

// 4 x 4 matrices to and from the column-major float[16] that OpenGL (and
// glTF, GLM) hold: element (row r, column c) sits at m[4 c + r], so a
// translation's t is at m[12], m[13], m[14]. `from` copies into a new leaf of
// `dtype`; a null pointer or a NaN/Inf element is a ValueError naming it.
// `to` reads any float [4, 4] tensor (ShapeError / DTypeError otherwise).
Tensor mat4_from_column_major(const float* m, DType dtype = DType::Float32);
Tensor mat4_from_column_major(const double* m, DType dtype = DType::Float32);
std::array<float, 16> mat4_to_column_major(const Tensor& matrix);
std::array<double, 16> mat4_to_column_major_f64(const Tensor& matrix);

}  // namespace gr
