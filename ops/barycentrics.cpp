#include "ops/barycentrics.h"

#include <string>

#include "ops/check.h"
#include "ops/elementwise.h"
#include "ops/fragments.h"
#include "ops/shape_ops.h"
#include "ops/vector.h"

namespace gr {
namespace {

// Per fragment: the three vertex indices of its triangle ([F, 3] int32).
Tensor fragment_vertices(const Tensor& triangles, const Fragments& fr) {
  const std::int64_t F = fr.count();
  Tensor out = Tensor::empty({F, 3}, DType::Int32);
  const std::int32_t *tri = triangles.data<std::int32_t>(), *id = fr.tri_id.data<std::int32_t>();
  std::int32_t* o = out.data<std::int32_t>();
  for (std::int64_t f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) o[3 * f + k] = tri[3 * (id[f] - 1) + k];
  return out;
}

// Per fragment: its pixel centre (x + 0.5, y + 0.5, 1), [F, 3] of `dtype`.
Tensor pixel_centres(const Fragments& fr, DType dtype) {
  const std::int64_t F = fr.count();
  std::vector<double> p(static_cast<std::size_t>(3 * F));
  const std::int32_t* pix = fr.pixel_index.data<std::int32_t>();
  for (std::int64_t f = 0; f < F; ++f) {
    p[3 * f] = pix[f] % fr.width + 0.5;
    p[3 * f + 1] = pix[f] / fr.width + 0.5;
    p[3 * f + 2] = 1.0;
  }
  return Tensor::from_values(p, {F, 3}, dtype);
}

// Column k of an [F, n] tensor, as [F, 1] (dot's result shape: everything per fragment stays [F, 1]).
Tensor column(const Tensor& a, int k) { return slice(a, 1, k, k + 1); }

// The fragments' b_k and db_k/dx, db_k/dy (k = 0, 1, 2), each [F, 1].
struct FragmentBarycentrics {
  Tensor b[3], dx[3], dy[3];
};

FragmentBarycentrics fragment_barycentrics(const Tensor& clip, const Tensor& triangles, const Fragments& fr) {
  const Tensor corners = gather(clip, fragment_vertices(triangles, fr));  // [F, 3, 4]
  const double half_w = 0.5 * fr.width, half_h = 0.5 * fr.height;
  Tensor V[3];
  for (int k = 0; k < 3; ++k) {
    const Tensor c = reshape(slice(corners, 1, k, k + 1), {fr.count(), 4});
    const Tensor x = column(c, 0), y = column(c, 1), w = column(c, 3);
    V[k] = concat({half_w * (x + w), half_h * (w - y), w}, 1);  // homogeneous screen vertex [F, 3]
  }
  const Tensor p = pixel_centres(fr, clip.dtype());
  Tensor c[3], F[3];
  for (int k = 0; k < 3; ++k) {
    c[k] = cross(V[(k + 1) % 3], V[(k + 2) % 3]);
    F[k] = dot(p, c[k]);
  }
  const Tensor S = F[0] + F[1] + F[2];
  const Tensor Sx = column(c[0], 0) + column(c[1], 0) + column(c[2], 0);
  const Tensor Sy = column(c[0], 1) + column(c[1], 1) + column(c[2], 1);
  const Tensor S2 = S * S;
  FragmentBarycentrics out;
  for (int k = 0; k < 3; ++k) {
    out.b[k] = F[k] / S;
    out.dx[k] = (column(c[k], 0) * S - F[k] * Sx) / S2;
    out.dy[k] = (column(c[k], 1) * S - F[k] * Sy) / S2;
  }
  return out;
}

void check_inputs(const Tensor& clip, const Tensor& triangles, const GBuffer& gb, const char* op) {
  detail::check_clip_and_triangles(clip, triangles, op);
  detail::check_defined(gb.tri_id, op, "gbuffer.tri_id");
  detail::check_dtype(gb.tri_id, DType::Int32, op, "gbuffer.tri_id");
  if (gb.tri_id.rank() != 2) throw ShapeError(std::string(op) + ": gbuffer.tri_id must be [H, W], got " + gb.tri_id.describe());
  detail::check_tri_ids(gb.tri_id, triangles.size(0), op);
  detail::check_gbuffer_source(gb, clip, triangles, op);
}

}  // namespace

PerspectiveBarycentrics perspective_barycentrics(const Tensor& clip, const Tensor& triangles, const GBuffer& gbuffer) {
  check_inputs(clip, triangles, gbuffer, "perspective_barycentrics");
  const Fragments fr = fragments(gbuffer);
  const FragmentBarycentrics fb = fragment_barycentrics(clip, triangles, fr);
  PerspectiveBarycentrics out;
  out.uv = to_image(concat({fb.b[1], fb.b[2]}, 1), fr);
  out.uv_db = to_image(concat({fb.dx[1], fb.dy[1], fb.dx[2], fb.dy[2]}, 1), fr);
  return out;
}

AttributeDerivatives attribute_derivatives(const Tensor& attributes, const Tensor& clip, const Tensor& triangles,
                                           const GBuffer& gbuffer) {
  const char* op = "attribute_derivatives";
  check_inputs(clip, triangles, gbuffer, op);
  detail::check_float(attributes, op, "attributes");
  detail::check_same_dtype(attributes, clip, op, "attributes", "clip");
  if (attributes.rank() != 2 || attributes.size(0) != clip.size(0))
    throw ShapeError(std::string(op) + ": attributes must be [N, C] with N = clip's " + std::to_string(clip.size(0)) +
                     " vertices, got " + attributes.describe());
  const Fragments fr = fragments(gbuffer);
  const FragmentBarycentrics fb = fragment_barycentrics(clip, triangles, fr);
  const Tensor a = gather(attributes, fragment_vertices(triangles, fr));  // [F, 3, C]
  const std::int64_t C = attributes.size(1);
  Tensor dx, dy;
  for (int k = 0; k < 3; ++k) {
    const Tensor ak = reshape(slice(a, 1, k, k + 1), {fr.count(), C});
    const Tensor tx = fb.dx[k] * ak, ty = fb.dy[k] * ak;
    dx = k == 0 ? tx : dx + tx;
    dy = k == 0 ? ty : dy + ty;
  }
  return {to_image(dx, fr), to_image(dy, fr)};
}

}  // namespace gr
