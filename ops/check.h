// Argument checks for ops, run once at the op boundary (kernels trust what
// they are given). Each throws the matching gr::Error with a message of one
// form: "<op>: argument '<name>' <what is wrong>, got <the tensor>", so a user
// sees which call, which argument and which problem.
#pragma once

#include <cstdint>
#include <string>

#include "autodiff/base/tensor.h"
#include "ops/render/rasterize.h"

namespace gr::detail {

// ValueError unless `t` is defined.
void check_defined(const Tensor& t, const std::string& op, const char* name);
// DTypeError unless `t` is defined and float32 or float64.
void check_float(const Tensor& t, const std::string& op, const char* name);
// DTypeError unless `t` is defined and of `dtype`.
void check_dtype(const Tensor& t, DType dtype, const std::string& op, const char* name);
// DTypeError unless `t` has the dtype of `ref` (named ref_name).
void check_same_dtype(const Tensor& t, const Tensor& ref, const std::string& op, const char* name,
                      const char* ref_name);
// Throws unless a and b are float tensors of the same dtype (binary math ops).
void check_same_float(const Tensor& a, const Tensor& b, const std::string& op);
// ShapeError unless `t` has exactly `shape`.
void check_shape(const Tensor& t, const Shape& shape, const std::string& op, const char* name);
// ShapeError unless `t` is [rows, cols] for any rows; `rows_name` names the
// free dimension in the message ("[N, 4]").
void check_columns(const Tensor& t, std::int64_t cols, const std::string& op, const char* name,
                   const char* rows_name = "N");
// ValueError naming the first element that is NaN or Inf (float tensors).
void check_finite(const Tensor& t, const std::string& op, const char* name);
// ValueError unless 1 <= width, height <= raster::kMaxSide and width * height <= 2^28.
void check_image_size(std::int64_t width, std::int64_t height, const std::string& op);
// triangles: int32 [M, 3] with every index in [0, num_vertices) (IndexError
// naming the triangle and corner: "tris[i][k] = v is outside [0, N)").
void check_triangles(const Tensor& triangles, std::int64_t num_vertices, const std::string& op);
// clip: float [N, 4]; triangles as check_triangles with num_vertices = N.
void check_clip_and_triangles(const Tensor& clip, const Tensor& triangles, const std::string& op);
// ValueError unless clip and triangles are the ones `gbuffer` was rasterized
// from (GBuffer::clip, ::triangles): the same tensors, or tensors of the same
// shape, dtype and bits. Passes a hand-made GBuffer (no clip recorded).
void check_gbuffer_source(const GBuffer& gbuffer, const Tensor& clip, const Tensor& triangles,
                          const std::string& op);
// tri_id: int32 [H, W] with every value in [0, num_tris] (IndexError naming the pixel).
void check_tri_ids(const Tensor& tri_id, std::int64_t num_tris, const std::string& op);

}  // namespace gr::detail
