// Linear blend of vertex attributes with stored barycentrics, and its adjoint
// (formulas in barycentric_interpolate.h). The forward blends 16 pixels at a
// time in vector lanes for 1 to 4 channels, and the adjoint's channel loops
// are unrolled for them, with the per-pixel loop's arithmetic in the same
// order (the same bits). The per-vertex sums scatter by gathering
// (docs/determinism.md): pixels grouped by triangle, summed per corner in
// pixel order, then per vertex in corner order, so the sums do not depend on
// the thread count.
#include "raster/barycentric_interpolate.h"

#include <algorithm>
#include <vector>

#include "autodiff/base/parallel.h"
#include "raster/detail/buckets.h"
#include "raster/detail/corner_gather.h"
#include "raster/detail/rasterize_setup.h"
#include "raster/detail/triangle_groups.h"

namespace gr::raster {
namespace {

template <class T>
std::int64_t pixel_triangle(const BarycentricInterpolateParams<T>& p, std::int64_t q) {
  // -1 = background
  return p.tri_id ? static_cast<std::int64_t>(p.tri_id[q]) - 1 : static_cast<std::int64_t>(p.rast[4 * q + 3]) - 1;
}

// Weights of the three vertices at pixel q, and their x and y derivatives.
struct Weights {
  double w[3], dx[3], dy[3];
};
template <class T>
Weights pixel_weights(const BarycentricInterpolateParams<T>& p, std::int64_t q) {
  const T* r = p.rast + p.rast_stride * q;
  Weights k;
  k.w[0] = r[0];
  k.w[1] = r[1];
  k.w[2] = 1.0 - k.w[0] - k.w[1];
  if (p.rast_db) {
    const T* d = p.rast_db + 4 * q;
    k.dx[0] = d[0], k.dy[0] = d[1], k.dx[1] = d[2], k.dy[1] = d[3];
    k.dx[2] = -k.dx[0] - k.dx[1];
    k.dy[2] = -k.dy[0] - k.dy[1];
  }
  return k;
}

}  // namespace

namespace {

// Pixels the forward takes at once in its vectorized loop (as
// raster/interpolate.cpp's kLanes: 16 lanes keep the lane arrays' reads clear
// of their writes' store forwarding).
constexpr int kLanes = 16;

// barycentric_interpolate_forward's values over pixels [lo, hi) for kC
// channels, vectorized across pixels: each batch's weights and attribute rows
// are gathered into per-lane arrays and blended lane by lane with the pixel
// loop's arithmetic in the same order (so the same bits); background lanes
// are written as zeros. kPlanes: the GBuffer's planes (ids from tri_id, rast
// of stride 2), else nvdiffrast's rast (stride 4, ids in channel 3); a
// stride known at compile time keeps the gather short (callgrind: the
// runtime stride cost 12 % more instructions than the interpolate of 1d1c318).
template <int kC, bool kPlanes, class T>
void forward_lanes_in(const BarycentricInterpolateParams<T>& p, std::int64_t lo, std::int64_t hi, T* out) {
  constexpr int kStride = kPlanes ? 2 : 4;
  for (std::int64_t q0 = lo; q0 < hi; q0 += kLanes) {
    const int n = static_cast<int>(std::min<std::int64_t>(kLanes, hi - q0));
    std::int64_t t[kLanes];  // -1 = background
    bool any_covered = false;
    for (int i = 0; i < kLanes; ++i) {
      if (i >= n)
        t[i] = -1;
      else if constexpr (kPlanes)
        t[i] = static_cast<std::int64_t>(p.tri_id[q0 + i]) - 1;
      else
        t[i] = static_cast<std::int64_t>(p.rast[4 * (q0 + i) + 3]) - 1;
      any_covered |= t[i] >= 0;
    }
    if (!any_covered) {  // all background (most of an image's corners)
      std::fill(out + q0 * kC, out + (q0 + n) * kC, T(0));
      continue;
    }
    // Gather (background lanes and lanes past n get zeros, unused).
    double w0[kLanes], w1[kLanes], a[3][kC][kLanes];
    const T* r = p.rast + kStride * q0;
    for (int i = 0; i < kLanes; ++i) {
      if (t[i] < 0) {
        w0[i] = w1[i] = 0.0;
        for (int k = 0; k < 3; ++k)
          for (int c = 0; c < kC; ++c) a[k][c][i] = 0.0;
        continue;
      }
      const std::int32_t* tri = p.tris + 3 * t[i];
      w0[i] = static_cast<double>(r[kStride * i]);
      w1[i] = static_cast<double>(r[kStride * i + 1]);
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < kC; ++c) a[k][c][i] = static_cast<double>(p.attr[tri[k] * kC + c]);
    }
    // A = b0 A_0 + b1 A_1 + (1 - b0 - b1) A_2, as pixel_weights and the pixel loop.
    double value[kC][kLanes];
    for (int i = 0; i < kLanes; ++i) {
      const double w2 = 1.0 - w0[i] - w1[i];
      for (int c = 0; c < kC; ++c) value[c][i] = w0[i] * a[0][c][i] + w1[i] * a[1][c][i] + w2 * a[2][c][i];
    }
    for (int i = 0; i < n; ++i) {
      T* o = out + (q0 + i) * kC;
      for (int c = 0; c < kC; ++c) o[c] = t[i] >= 0 ? static_cast<T>(value[c][i]) : T(0);
    }
  }
}

template <int kC, class T>
void forward_lanes(const BarycentricInterpolateParams<T>& p, std::int64_t lo, std::int64_t hi, T* out) {
  if (p.tri_id)
    forward_lanes_in<kC, true>(p, lo, hi, out);
  else
    forward_lanes_in<kC, false>(p, lo, hi, out);
}

}  // namespace

template <class T>
void barycentric_interpolate_forward(const BarycentricInterpolateParams<T>& p, T* out, T* out_da) {
  const std::int64_t C = p.channels, K = p.num_diff;
  parallel_for(0, p.pixels, 2048, [&](std::int64_t lo, std::int64_t hi) {
    // The usual channel counts and layouts, vectorized.
    const bool lanes = !out_da && C >= 1 && C <= 4 && p.rast_stride == (p.tri_id ? 2 : 4);
    if (lanes) {
      switch (C) {
        case 1: forward_lanes<1>(p, lo, hi, out); return;
        case 2: forward_lanes<2>(p, lo, hi, out); return;
        case 3: forward_lanes<3>(p, lo, hi, out); return;
        default: forward_lanes<4>(p, lo, hi, out); return;
      }
    }
    for (std::int64_t q = lo; q < hi; ++q) {
      T* o = out + q * C;
      T* od = out_da ? out_da + q * 2 * K : nullptr;
      const std::int64_t t = pixel_triangle(p, q);
      if (t < 0) {
        std::fill(o, o + C, T(0));
        if (od) std::fill(od, od + 2 * K, T(0));
        continue;
      }
      const std::int32_t* tri = p.tris + 3 * t;
      const T* a[3] = {p.attr + tri[0] * C, p.attr + tri[1] * C, p.attr + tri[2] * C};
      const Weights k = pixel_weights(p, q);
      for (std::int64_t c = 0; c < C; ++c) o[c] = static_cast<T>(k.w[0] * a[0][c] + k.w[1] * a[1][c] + k.w[2] * a[2][c]);
      if (!od) continue;
      for (std::int64_t j = 0; j < K; ++j) {
        const std::int32_t c = p.diff[j];
        od[2 * j] = static_cast<T>(k.dx[0] * a[0][c] + k.dx[1] * a[1][c] + k.dx[2] * a[2][c]);
        od[2 * j + 1] = static_cast<T>(k.dy[0] * a[0][c] + k.dy[1] * a[1][c] + k.dy[2] * a[2][c]);
      }
    }
  });
}

namespace {

// The adjoint's buffers, reused across calls (no page faults after the first).
detail::ScratchPool<detail::GatherScratch> g_backward_pool;

// barycentric_interpolate_backward for kC channels (0: p.channels), so the
// usual channel counts get unrolled channel loops; the same arithmetic in the
// same order either way.
template <int kC, class T>
void backward_channels(const BarycentricInterpolateParams<T>& p, const T* grad_out, const T* grad_da,
                       const BarycentricInterpolateGrads<T>& grads) {
  const std::int64_t C = kC > 0 ? kC : p.channels, K = grad_da ? p.num_diff : 0;
  // Per pixel: gradients of the barycentrics and their derivatives.
  const bool per_pixel = grads.rast || (grads.rast_db && K > 0);
  // Pixel q's gradients, a = its triangle's three attribute rows.
  auto pixel_grads = [&](std::int64_t q, const T* const* a) {
    if (grads.rast) {
      const T* g = grad_out + q * C;
      double g0 = 0.0, g1 = 0.0;
      for (std::int64_t c = 0; c < C; ++c) {
        g0 += static_cast<double>(g[c]) * (static_cast<double>(a[0][c]) - a[2][c]);
        g1 += static_cast<double>(g[c]) * (static_cast<double>(a[1][c]) - a[2][c]);
      }
      grads.rast[p.rast_stride * q] += static_cast<T>(g0);
      grads.rast[p.rast_stride * q + 1] += static_cast<T>(g1);
    }
    if (grads.rast_db && K > 0) {
      const T* h = grad_da + q * 2 * K;
      double d[4] = {0, 0, 0, 0};
      for (std::int64_t j = 0; j < K; ++j) {
        const std::int32_t c = p.diff[j];
        const double e0 = static_cast<double>(a[0][c]) - a[2][c], e1 = static_cast<double>(a[1][c]) - a[2][c];
        d[0] += h[2 * j] * e0;
        d[1] += h[2 * j + 1] * e0;
        d[2] += h[2 * j] * e1;
        d[3] += h[2 * j + 1] * e1;
      }
      for (int i = 0; i < 4; ++i) grads.rast_db[4 * q + i] += static_cast<T>(d[i]);
    }
  };
  if (!grads.attr) {
    if (per_pixel)
      parallel_for(0, p.pixels, 2048, [&](std::int64_t lo, std::int64_t hi) {
        for (std::int64_t q = lo; q < hi; ++q) {
          const std::int64_t t = pixel_triangle(p, q);
          if (t < 0) continue;
          const std::int32_t* tri = p.tris + 3 * t;
          const T* a[3] = {p.attr + tri[0] * C, p.attr + tri[1] * C, p.attr + tri[2] * C};
          pixel_grads(q, a);
        }
      });
    return;
  }
  // Scatter by gathering (docs/determinism.md): 1. covered pixels grouped by
  // triangle, in ascending pixel order; the used triangles numbered by first pixel.
  auto lease = g_backward_pool.take();
  detail::GatherScratch& sc = *lease;
  const detail::Buckets* shared = p.groups && p.tri_id ? p.groups->by_triangle(p.tri_id, p.pixels, p.num_tris) : nullptr;
  if (!shared)
    detail::bucket_items(p.pixels, p.num_tris, [&](std::int64_t q) { return pixel_triangle(p, q); }, &sc.by_tri);
  const detail::Buckets& by_tri = shared ? *shared : sc.by_tri;
  const std::int64_t used = static_cast<std::int64_t>(by_tri.nonempty.size());
  // 2. Per used triangle s, in parallel: its pixels' terms summed per corner
  // in pixel order (corner k at partial[(3 s + k) C]), and the per-pixel gradients.
  sc.partial.resize(static_cast<std::size_t>(3 * used * C));
  double* const partial = sc.partial.data();
  parallel_for(0, used, 16, [&](std::int64_t s0, std::int64_t s1) {
    for (std::int64_t s = s0; s < s1; ++s) {
      const std::int32_t t = by_tri.nonempty[s];
      const std::int32_t* tri = p.tris + 3 * static_cast<std::int64_t>(t);
      const T* a[3] = {p.attr + tri[0] * C, p.attr + tri[1] * C, p.attr + tri[2] * C};
      // The corners' sums: in a local array for the unrolled channel counts
      // (kept in registers), else in place; the same additions in the same order.
      double local[kC > 0 ? 3 * kC : 1];
      double* acc = kC > 0 ? local : partial + 3 * s * C;
      std::fill(acc, acc + 3 * C, 0.0);
      for (std::int64_t e = by_tri.start[t]; e < by_tri.start[t + 1]; ++e) {
        const std::int64_t q = by_tri.item[e];
        if (per_pixel) pixel_grads(q, a);
        // dL/dA_k += b_k g + (db_k/dx h_x + db_k/dy h_y) on the selected channels.
        const Weights w = pixel_weights(p, q);
        const T* g = grad_out + q * C;
        const T* h = K > 0 ? grad_da + q * 2 * K : nullptr;
        for (int k = 0; k < 3; ++k) {
          double* o = acc + k * C;
          for (std::int64_t c = 0; c < C; ++c) o[c] += w.w[k] * g[c];
          for (std::int64_t j = 0; j < K; ++j) o[p.diff[j]] += w.dx[k] * h[2 * j] + w.dy[k] * h[2 * j + 1];
        }
      }
      if (kC > 0) std::copy(acc, acc + 3 * C, partial + 3 * s * C);
    }
  });
  // 3. Each vertex adds its corners' sums in corner order, once (the
  // corners grouped by vertex once per G-buffer and triangle list).
  const detail::Buckets* corners =
      shared ? p.groups->corners_by_vertex(p.tri_id, p.tris, p.num_tris, p.num_vertices) : nullptr;
  if (!corners) {
    detail::group_corners(p.tris, by_tri.nonempty.data(), used, nullptr, p.num_vertices, &sc.by_vertex);
    corners = &sc.by_vertex;
  }
  detail::sum_corners(*corners, partial, C, [&](std::int64_t v, const double* total) {
    T* ga = grads.attr + v * C;
    for (std::int64_t c = 0; c < C; ++c) ga[c] += static_cast<T>(total[c]);
  });
}

}  // namespace

template <class T>
void barycentric_interpolate_backward(const BarycentricInterpolateParams<T>& p, const T* grad_out,
                                      const T* grad_da, const BarycentricInterpolateGrads<T>& grads) {
  switch (p.channels) {
    case 1: backward_channels<1>(p, grad_out, grad_da, grads); return;
    case 2: backward_channels<2>(p, grad_out, grad_da, grads); return;
    case 3: backward_channels<3>(p, grad_out, grad_da, grads); return;
    case 4: backward_channels<4>(p, grad_out, grad_da, grads); return;
    default: backward_channels<0>(p, grad_out, grad_da, grads); return;
  }
}

#define GR_INSTANTIATE(T)                                                                                  \
  template void barycentric_interpolate_forward<T>(const BarycentricInterpolateParams<T>&, T*, T*);         \
  template void barycentric_interpolate_backward<T>(const BarycentricInterpolateParams<T>&, const T*, const T*, \
                                                    const BarycentricInterpolateGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
