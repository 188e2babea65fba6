// nvdiffrast-layout G-buffer from a coverage image, and its adjoint
// (formulas in barycentric_gbuffer.h). Per pixel everything is evaluated in
// double from the three homogeneous screen vertices; the adjoint scatters by
// gathering (docs/determinism.md): pixels grouped by triangle, each
// triangle's terms computed once, its pixels' cotangents (dL/dc_k, dL/dD,
// dL/dz_k) summed in pixel order and the chain to clip applied once per
// triangle, then each vertex's corners added in a fixed order.
#include "raster/barycentric_gbuffer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/buckets.h"
#include "raster/detail/corner_gather.h"
#include "raster/detail/guarded_math.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/triangle_groups.h"

namespace gr::raster {
namespace {

using detail::cross;
using detail::finite_cast;
using detail::dot;
using detail::HVec;

// The homogeneous quantities of one triangle (the same for all its pixels,
// so consecutive pixels of one triangle compute them once).
struct TriangleTerms {
  HVec V[3], c[3], C;
  double D, z[3];
};

template <class T>
TriangleTerms triangle_terms(const BarycentricGBufferParams<T>& p, std::int64_t tri) {
  TriangleTerms t;
  const std::int32_t* idx = p.tris + 3 * tri;
  const double hw = 0.5 * p.width, hh = 0.5 * p.height;
  for (int k = 0; k < 3; ++k) {
    const T* v = p.clip + 4 * static_cast<std::int64_t>(idx[k]);
    const double x = v[0], y = detail::seen_y(v[1], p.y_up), w = v[3];
    t.V[k] = {hw * (x + w), hh * (w - y), w};
    t.z[k] = v[2];
  }
  t.C = {0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) {
    t.c[k] = cross(t.V[(k + 1) % 3], t.V[(k + 2) % 3]);
    t.C = {t.C.x + t.c[k].x, t.C.y + t.c[k].y, t.C.w + t.c[k].w};
  }
  t.D = dot(t.V[0], t.c[0]);
  return t;
}

// The adjoint's coverage: pixel q's 1-based id (0 = background).
template <class T>
std::int64_t pixel_id(const BarycentricGBufferParams<T>& p, const T* rast, std::int64_t q) {
  return p.tri_id ? static_cast<std::int64_t>(p.tri_id[q]) : static_cast<std::int64_t>(rast[4 * q + 3]);
}

// The cotangents after which the adjoint is linear with per-triangle
// constants (V_k, c_k): dL/dc_k, dL/dD and dL/dz_k. A triangle's pixels add
// theirs into one sum (in pixel order) and the chain to clip runs once per
// triangle (triangle_adjoint), not per pixel.
struct Cotangents {
  HVec c[3];
  double D, z[3];
};

// Adds pixel (ex, ey)'s cotangents to `sum` and returns true, or returns
// false where S is zero or not finite (the caller checks D once per
// triangle). With g_k the gradients of b_k (g_2 = 0), g_z of z/w and h the
// derivatives' gradients (or null):
//   dL/da_k = (g_k - sum_j g_j b_j) / S + g_z z_k / D - (h_k.x C.x + h_k.y C.y) / S^2 + dL/dS,
//   dL/dS = sum_k (2 a_k (h_k.x C.x + h_k.y C.y) / S - (h_k.x c_k.x + h_k.y c_k.y)) / S^2,
//   dL/dc_k = dL/da_k e + (h_k.x, h_k.y, 0) / S + dL/dC,  dL/dC.d = -sum_k h_k.d a_k / S^2,
//   dL/dD = -g_z (z/w) / D,  dL/dz_k = g_z a_k / D.
template <class T>
bool add_pixel_cotangents(const TriangleTerms& t, double ex, double ey, double g0, double g1, double gz,
                          const T* g_db, Cotangents& sum) {
  double a[3];
  for (int k = 0; k < 3; ++k) a[k] = ex * t.c[k].x + ey * t.c[k].y + t.c[k].w;  // a_k = e . c_k
  const double S = a[0] + a[1] + a[2];
  if (!(S != 0.0 && std::isfinite(S))) return false;
  const double r = 1.0 / S;
  // b_k = a_k / S.
  const double gb = (g0 * a[0] + g1 * a[1]) * r;
  double bar_a[3] = {(g0 - gb) * r, (g1 - gb) * r, -gb * r};
  if (gz != 0.0) {  // z/w = sum a_k z_k / D
    const double gD = gz / t.D;
    const double zw = a[0] * t.z[0] + a[1] * t.z[1] + a[2] * t.z[2];
    for (int k = 0; k < 3; ++k) {
      bar_a[k] += gD * t.z[k];
      sum.z[k] += gD * a[k];
    }
    sum.D -= gD * zw / t.D;
  }
  // db_k/dd = c_k.d / S - a_k C.d / S^2 for d in {x, y}.
  double bar_S = 0.0, bar_Cx = 0.0, bar_Cy = 0.0;
  if (g_db) {
    const double r2 = r * r;
    for (int k = 0; k < 2; ++k) {
      const double hx = g_db[2 * k], hy = g_db[2 * k + 1];
      const double hC = hx * t.C.x + hy * t.C.y;
      sum.c[k].x += hx * r;
      sum.c[k].y += hy * r;
      bar_Cx -= hx * a[k] * r2;
      bar_Cy -= hy * a[k] * r2;
      bar_a[k] -= hC * r2;
      bar_S += (2.0 * a[k] * hC * r - (hx * t.c[k].x + hy * t.c[k].y)) * r2;
    }
  }
  // a_k = e . c_k, S = sum a_k, C = sum c_k.
  for (int k = 0; k < 3; ++k) {
    const double ba = bar_a[k] + bar_S;
    sum.c[k] = {sum.c[k].x + (ba * ex + bar_Cx), sum.c[k].y + (ba * ey + bar_Cy), sum.c[k].w + ba};
  }
  return true;
}

// dL/dclip of the three vertices (12 values, vertex k at out[4 k]) from a
// triangle's summed cotangents: dL/dV_j = dL/dD c_j + (c_k = V_k+1 x V_k+2:
// dL/dV_k+1 += V_k+2 x dL/dc_k, dL/dV_k+2 += dL/dc_k x V_k+1), then V -> clip.
template <class T>
void triangle_adjoint(const BarycentricGBufferParams<T>& p, const TriangleTerms& t, const Cotangents& sum,
                      double* out) {
  HVec bar_V[3];
  for (int k = 0; k < 3; ++k) bar_V[k] = {sum.D * t.c[k].x, sum.D * t.c[k].y, sum.D * t.c[k].w};
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    const HVec d1 = cross(t.V[k2], sum.c[k]), d2 = cross(sum.c[k], t.V[k1]);
    bar_V[k1] = {bar_V[k1].x + d1.x, bar_V[k1].y + d1.y, bar_V[k1].w + d1.w};
    bar_V[k2] = {bar_V[k2].x + d2.x, bar_V[k2].y + d2.y, bar_V[k2].w + d2.w};
  }
  // V = (W/2 (x + w), H/2 (w - y), w) -> clip; with y_up V holds -y, so
  // dL/dy = +H/2 dL/dV.y (the negation of -H/2 dL/dV.y, exact).
  const double hw = 0.5 * p.width, hh = 0.5 * p.height, hy = p.y_up ? hh : -hh;
  for (int k = 0; k < 3; ++k) {
    double* o = out + 4 * k;
    o[0] = hw * bar_V[k].x;
    o[1] = hy * bar_V[k].y;
    o[2] = sum.z[k];
    o[3] = hw * bar_V[k].x + hh * bar_V[k].y + bar_V[k].w;
  }
}

}  // namespace

namespace {

// What the forward reads of a triangle's terms (TriangleTerms without V and
// C.w), computed with triangle_terms' arithmetic in the same order, so the
// same bits.
struct ForwardTerms {
  HVec c[3];
  double Cx, Cy, D, z[3];
};

template <class T>
ForwardTerms forward_terms(const BarycentricGBufferParams<T>& p, std::int64_t tri) {
  ForwardTerms t;
  const std::int32_t* idx = p.tris + 3 * tri;
  const double hw = 0.5 * p.width, hh = 0.5 * p.height;
  HVec V[3];
  for (int k = 0; k < 3; ++k) {
    const T* v = p.clip + 4 * static_cast<std::int64_t>(idx[k]);
    const double x = v[0], y = detail::seen_y(v[1], p.y_up), w = v[3];
    V[k] = {hw * (x + w), hh * (w - y), w};
    t.z[k] = v[2];
  }
  double Cx = 0.0, Cy = 0.0;
  for (int k = 0; k < 3; ++k) {
    t.c[k] = cross(V[(k + 1) % 3], V[(k + 2) % 3]);
    Cx = Cx + t.c[k].x;
    Cy = Cy + t.c[k].y;
  }
  t.Cx = Cx;
  t.Cy = Cy;
  t.D = dot(V[0], t.c[0]);
  return t;
}

// The terms of the last triangles seen, direct-mapped by id: a row crosses
// about a hundred triangles at 256 x 256 and the next rows cross most of them
// again. bench_iteration's sphere at 256 x 256 (callgrind): with 64 slots the
// terms were made at 83 % of the covered pixels, with 512 at 49 %, about once
// per visible triangle.
class ForwardCache {
 public:
  static constexpr std::size_t kSlots = 512;
  void clear() { tri_.fill(-1); }
  template <class T>
  const ForwardTerms& at(const BarycentricGBufferParams<T>& p, std::int64_t tri) {
    const std::size_t slot = static_cast<std::size_t>(tri) % kSlots;
    if (tri_[slot] != tri) terms_[slot] = forward_terms(p, tri), tri_[slot] = tri;
    return terms_[slot];
  }

 private:
  std::array<std::int64_t, kSlots> tri_;
  std::array<ForwardTerms, kSlots> terms_;
};

// The caches (60 KB each) are reused across calls, one per running chunk.
detail::ScratchPool<ForwardCache> g_forward_pool;

// One covered pixel's values at centre e = (ex, ey, 1) (formulas in
// barycentric_gbuffer.h; a_k = e . c_k, S = sum a_k and the clamps in the
// order the adjoint recomputes them), all zero where S or D is zero or not finite. db only with kDerivatives.
struct PixelValues {
  double b0, b1, zw;
  double db[4];
};

template <bool kDerivatives>
[[gnu::always_inline]] inline void pixel_values(const ForwardTerms& t, double ex, double ey, PixelValues* v) {
  const HVec e{ex, ey, 1.0};
  double a[3], S = 0.0;
  for (int k = 0; k < 3; ++k) {
    a[k] = dot(e, t.c[k]);
    S += a[k];
  }
  if (!(S != 0.0 && t.D != 0.0 && std::isfinite(S) && std::isfinite(t.D))) {
    v->b0 = v->b1 = v->zw = 0.0;
    if (kDerivatives) v->db[0] = v->db[1] = v->db[2] = v->db[3] = 0.0;
    return;
  }
  double b0 = std::clamp(a[0] / S, 0.0, 1.0), b1 = std::clamp(a[1] / S, 0.0, 1.0);
  const double sum = b0 + b1;
  if (sum > 1.0) b0 /= sum, b1 /= sum;
  double zw = 0.0;
  for (int k = 0; k < 3; ++k) zw += a[k] * t.z[k];
  v->b0 = b0;
  v->b1 = b1;
  v->zw = std::clamp(zw / t.D, -1.0, 1.0);
  if (!kDerivatives) return;
  const double S2 = S * S;
  if (S2 != 0.0 && std::isfinite(S2)) {
    for (int k = 0; k < 2; ++k) {
      v->db[2 * k] = (t.c[k].x * S - a[k] * t.Cx) / S2;
      v->db[2 * k + 1] = (t.c[k].y * S - a[k] * t.Cy) / S2;
    }
    return;
  }
  // S^2 under- or overflows (|S| ~ |clip|^2 below 2^-511 or above 2^511:
  // float64 clip far from 1, or float32 denormals, beyond any device's float
  // arithmetic): the same quotient as (c_k - b_k C) / S, which never squares
  // S. (The form above gave 0 or +-DBL_MAX there: clip scaled by 2^-330 had
  // no derivatives.)
  for (int k = 0; k < 2; ++k) {
    const double bk = a[k] / S;
    v->db[2 * k] = (t.c[k].x - bk * t.Cx) / S;
    v->db[2 * k + 1] = (t.c[k].y - bk * t.Cy) / S;
  }
}

// Where the forward writes: nvdiffrast's rast (H*W*4: b0, b1, z/w, id), or
// the C++ GBuffer's planes uv (H*W*2) and depth (H*W, background_depth on
// the background); db (H*W*4) or null either way.
template <class T>
struct ForwardOutputs {
  T* rast = nullptr;
  T* uv = nullptr;
  T* depth = nullptr;
  T background_depth = T(0);
  T* db = nullptr;
};

// The forward over whole rows, in parallel: each pixel's values from its
// triangle's terms (cached) and its centre (x + 0.5, y + 0.5) in double.
template <bool kPlanes, bool kDerivatives, class T>
void forward_rows(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, std::int64_t id_offset,
                  const ForwardOutputs<T>& o) {
  const int W = p.width;
  parallel_for(0, p.height, std::max(1, 4096 / W), [&](std::int64_t y0, std::int64_t y1) {
    auto lease = g_forward_pool.take();
    ForwardCache& cache = *lease;
    cache.clear();
    for (std::int64_t y = y0; y < y1; ++y) {
      const double ey = static_cast<double>(y) + 0.5;
      for (int x = 0; x < W; ++x) {
        const std::int64_t q = y * W + x;
        const std::int32_t id = tri_id[q];
        PixelValues v;
        std::int64_t tri = -1;
        if (id != 0) {
          tri = id_offset + id - 1;
          pixel_values<kDerivatives>(cache.at(p, tri), static_cast<double>(x) + 0.5, ey, &v);
        } else {
          v.b0 = v.b1 = v.zw = 0.0;
          if (kDerivatives) v.db[0] = v.db[1] = v.db[2] = v.db[3] = 0.0;
        }
        if constexpr (kPlanes) {
          o.uv[2 * q] = static_cast<T>(v.b0);
          o.uv[2 * q + 1] = static_cast<T>(v.b1);
          o.depth[q] = id != 0 ? static_cast<T>(v.zw) : o.background_depth;
        } else {
          T* r = o.rast + 4 * q;
          r[0] = static_cast<T>(v.b0);
          r[1] = static_cast<T>(v.b1);
          r[2] = static_cast<T>(v.zw);
          r[3] = static_cast<T>(tri + 1);
        }
        if constexpr (kDerivatives)
          for (int i = 0; i < 4; ++i) o.db[4 * q + i] = finite_cast<T>(v.db[i]);
      }
    }
  });
}

template <bool kPlanes, class T>
void forward_rows(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, std::int64_t id_offset,
                  const ForwardOutputs<T>& o) {
  if (o.db)
    forward_rows<kPlanes, true>(p, tri_id, id_offset, o);
  else
    forward_rows<kPlanes, false>(p, tri_id, id_offset, o);
}

}  // namespace

template <class T>
void barycentric_gbuffer_forward(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id,
                                 std::int64_t id_offset, T* rast, T* db) {
  ForwardOutputs<T> o;
  o.rast = rast;
  o.db = db;
  forward_rows<false>(p, tri_id, id_offset, o);
}

template <class T>
void barycentric_gbuffer_forward_planes(const BarycentricGBufferParams<T>& p, const std::int32_t* tri_id, T* uv,
                                        T* depth, T background_depth, T* db) {
  ForwardOutputs<T> o;
  o.uv = uv;
  o.depth = depth;
  o.background_depth = background_depth;
  o.db = db;
  forward_rows<true>(p, tri_id, 0, o);
}

namespace {

// The adjoint's buffers, reused across calls (no page faults after the first).
detail::ScratchPool<detail::GatherScratch> g_backward_pool;

// Where the adjoint reads pixel q's gradients of b0, b1 (uv[uv_stride q],
// uv[uv_stride q + 1]) and z/w (depth[depth_stride q]): rast's layout or
// the GBuffer's uv and depth planes; a missing plane reads a zero (stride 0).
template <class T>
struct RastGrads {
  const T* uv;
  std::int64_t uv_stride;
  const T* depth;
  std::int64_t depth_stride;
};

template <class T>
void backward_impl(const BarycentricGBufferParams<T>& p, const T* rast, const RastGrads<T>& grads, const T* grad_db,
                   T* grad_clip) {
  const std::int64_t pixels = static_cast<std::int64_t>(p.width) * p.height;
  // Scatter by gathering (docs/determinism.md): 1. covered pixels grouped by
  // triangle, in ascending pixel order; the used triangles numbered by first pixel.
  auto lease = g_backward_pool.take();
  detail::GatherScratch& sc = *lease;
  const detail::Buckets* shared = p.groups && p.tri_id ? p.groups->by_triangle(p.tri_id, pixels, p.num_tris) : nullptr;
  if (!shared)
    detail::bucket_items(pixels, p.num_tris, [&](std::int64_t q) { return pixel_id(p, rast, q) - 1; }, &sc.by_tri);
  const detail::Buckets& by_tri = shared ? *shared : sc.by_tri;
  const std::int64_t used = static_cast<std::int64_t>(by_tri.nonempty.size());
  // 2. Per used triangle s, in parallel: its pixels' cotangents summed in
  // pixel order, then the chain to the three vertices' dL/dclip once (corner
  // k at partial[4 (3 s + k)]).
  sc.partial.resize(static_cast<std::size_t>(12 * used));
  sc.live.resize(static_cast<std::size_t>(used));
  double* const partial = sc.partial.data();
  const std::int64_t width = p.width;
  parallel_for(0, used, 16, [&](std::int64_t s0, std::int64_t s1) {
    for (std::int64_t s = s0; s < s1; ++s) {
      const std::int32_t tri = by_tri.nonempty[s];
      std::optional<TriangleTerms> terms;  // computed at the first pixel with a gradient
      bool d_valid = false;                // D nonzero and finite (else no pixel contributes)
      Cotangents sum{};
      bool any_valid = false;
      std::int64_t row_start = 0, row_end = 0;  // pixel q's row, kept across the ascending pixels
      double ey = 0.0;
      for (std::int64_t e = by_tri.start[tri]; e < by_tri.start[tri + 1]; ++e) {
        const std::int64_t q = by_tri.item[e];
        const T* g = grads.uv + grads.uv_stride * q;
        const T gz = grads.depth[grads.depth_stride * q];
        const T* h = grad_db ? grad_db + 4 * q : nullptr;
        bool any = g[0] != T(0) || g[1] != T(0) || gz != T(0);
        if (h) any = any || h[0] != T(0) || h[1] != T(0) || h[2] != T(0) || h[3] != T(0);
        if (!any) continue;
        if (!terms) {
          terms = triangle_terms(p, tri);
          d_valid = terms->D != 0.0 && std::isfinite(terms->D);
        }
        if (!d_valid) break;
        if (q >= row_end) {
          const std::int64_t y = q / width;
          row_start = y * width, row_end = row_start + width, ey = static_cast<double>(y) + 0.5;
        }
        any_valid |= add_pixel_cotangents(*terms, static_cast<double>(q - row_start) + 0.5, ey, g[0], g[1], gz, h,
                                          sum);
      }
      // A triangle without a valid pixel adds nothing (its c_k or V_k may not be finite).
      sc.live[s] = any_valid ? 1 : 0;
      if (any_valid) triangle_adjoint(p, *terms, sum, partial + 12 * s);
    }
  });
  // 3. Each vertex adds its corners' sums in corner order, once.
  detail::gather_corners(p.tris, by_tri.nonempty.data(), used, sc.live.data(), partial, 4, p.num_vertices,
                         &sc.by_vertex, [&](std::int64_t v, const double* total) {
                           for (int j = 0; j < 4; ++j) grad_clip[4 * v + j] += finite_cast<T>(total[j]);
                         });
}

}  // namespace

template <class T>
void barycentric_gbuffer_backward(const BarycentricGBufferParams<T>& p, const T* rast, const T* grad_rast,
                                  const T* grad_db, T* grad_clip) {
  backward_impl(p, rast, RastGrads<T>{grad_rast, 4, grad_rast + 2, 4}, grad_db, grad_clip);
}

template <class T>
void barycentric_gbuffer_backward_planes(const BarycentricGBufferParams<T>& p, const T* grad_uv, const T* grad_depth,
                                         const T* grad_db, T* grad_clip) {
  static const T kZero[2] = {T(0), T(0)};
  const RastGrads<T> grads{grad_uv ? grad_uv : kZero, grad_uv ? 2 : 0, grad_depth ? grad_depth : kZero,
                           grad_depth ? 1 : 0};
  backward_impl(p, static_cast<const T*>(nullptr), grads, grad_db, grad_clip);
}

#define GR_INSTANTIATE(T)                                                                                       \
  template void barycentric_gbuffer_forward<T>(const BarycentricGBufferParams<T>&, const std::int32_t*,         \
                                               std::int64_t, T*, T*);                                           \
  template void barycentric_gbuffer_forward_planes<T>(const BarycentricGBufferParams<T>&, const std::int32_t*,  \
                                                      T*, T*, T, T*);                                           \
  template void barycentric_gbuffer_backward<T>(const BarycentricGBufferParams<T>&, const T*, const T*, const T*, \
                                                T*);                                                            \
  template void barycentric_gbuffer_backward_planes<T>(const BarycentricGBufferParams<T>&, const T*, const T*,  \
                                                       const T*, T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
