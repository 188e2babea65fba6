// Internal helpers shared by the op implementations: broadcasting rules,
// materializing a broadcast, summing a gradient back to an operand's shape,
// and argument checks. Nothing here records on the tape.
#pragma once

#include <string>

#include "autodiff/tensor.h"

namespace gr::detail {

// NumPy broadcast of two shapes; throws ShapeError naming the op and both shapes.
Shape broadcast_shapes(const Shape& a, const Shape& b, const std::string& op);

// `t` itself if it already has shape `out` or has one element (kernels treat
// a one-element operand as a scalar); otherwise a new tensor with t repeated
// along its broadcast axes.
Tensor expand_raw(const Tensor& t, const Shape& out);

// Like expand_raw, but one-element tensors are repeated too: the result
// always has shape `out` (t itself if it already has).
Tensor expand_raw_full(const Tensor& t, const Shape& out);

// Sums `g` over the axes along which `target` was broadcast to g's shape.
// Returns g itself when the shapes are equal. Deterministic for any thread count.
Tensor reduce_raw(const Tensor& g, const Shape& target);

// Throws unless `t` is defined and float32/float64 ("op: argument 'name' ...").
void check_float(const Tensor& t, const std::string& op, const char* name);
// Throws unless a and b are float tensors of the same dtype.
void check_same_float(const Tensor& a, const Tensor& b, const std::string& op);

// Throws unless clip is a float [N, 4] tensor and triangles an int32 [M, 3] one.
void check_clip_and_triangles(const Tensor& clip, const Tensor& triangles, const std::string& op);

}  // namespace gr::detail
