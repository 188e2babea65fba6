// Texture sampling forward. Every filter is reduced to a list of at most 8
// taps (raster/detail/texture_taps.h: texel index in the all-levels buffer, weight,
// d weight/du, d weight/dv): the forward sums weight * texel, and for the
// bilinear filter can save d out/du, d out/dv for the adjoint. The adjoint
// (raster/texture_backward.cpp) sums the weight derivatives for uv and
// scatters weight * g to the texels.
#include "raster/texture.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/base/tensor.h"
#include "raster/mesh_checks.h"  // detail::check_finite
#include "raster/detail/texture_taps.h"

namespace gr::raster {
using namespace texture_taps;
namespace {

// Bilinear lookups that also write d out/du, d out/dv = sum_t dw_t/du texel_t
// (and v) for the adjoint. The taps of kAhead samples come first and their
// texels are prefetched, so the (cache-missing) texel reads overlap.
template <class T>
void bilinear_forward_with_jacobian(const TextureParams<T>& p, T* out, T* uv_jacobian) {
  const std::int64_t C = p.channels;
  parallel_for(0, p.num_samples, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t s0 = lo; s0 < hi; s0 += kAhead) {
      const int n = static_cast<int>(std::min<std::int64_t>(kAhead, hi - s0));
      Taps taps[kAhead];
      for (int i = 0; i < n; ++i) {
        bilinear_taps<true>(p.layout.levels[0], p.uv[2 * (s0 + i)], p.uv[2 * (s0 + i) + 1], p.v_down, 1.0, p.wrap,
                            taps[i]);
        for (int k = 0; k < 4; ++k) __builtin_prefetch(p.tex + taps[i].index[k] * C);
      }
      for (int i = 0; i < n; ++i) {
        const Taps& t = taps[i];
        const T* tx[4];
        for (int k = 0; k < 4; ++k) tx[k] = p.tex + t.index[k] * C;
        T* o = out + (s0 + i) * C;
        T* ju = uv_jacobian + (s0 + i) * 2 * C;
        T* jv = ju + C;
        for (std::int64_t c = 0; c < C; ++c) {
          double a = 0.0, du = 0.0, dv = 0.0;
          for (int k = 0; k < 4; ++k) {
            const double x = tx[k][c];
            a += t.w[k] * x;
            du += t.dw_du[k] * x;
            dv += t.dw_dv[k] * x;
          }
          o[c] = static_cast<T>(a);
          ju[c] = static_cast<T>(du);
          jv[c] = static_cast<T>(dv);
        }
      }
    }
  });
}

}  // namespace

namespace texture_taps {

Lod compute_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height, int levels,
                double bias, LodRule rule) {
  // Footprint of one pixel step along x and along y, in level-0 texels.
  Lod l;
  l.ax = du_dx * width, l.ay = dv_dx * height, l.bx = du_dy * width, l.by = dv_dy * height;
  const double A = l.ax * l.ax + l.ay * l.ay, B = l.bx * l.bx + l.by * l.by;
  if (rule == LodRule::Isotropic) {
    const bool along_x = !(A < B);
    l.rho2 = along_x ? A : B;
    (along_x ? l.pA : l.pB) = 1.0;
  } else {
    // Squared major axis of the ellipse with quadratic form [[A, C], [C, B]].
    const double C = l.ax * l.bx + l.ay * l.by, h = 0.5 * (A - B);
    const double r = std::sqrt(h * h + C * C);
    l.rho2 = 0.5 * (A + B) + r;
    l.pA = r > 0 ? 0.5 + 0.5 * h / r : 0.5;
    l.pB = r > 0 ? 0.5 - 0.5 * h / r : 0.5;
    l.pC = r > 0 ? C / r : 0.0;
  }
  const double raw = 0.5 * std::log2(l.rho2) + bias;
  l.free = raw > 0.0 && raw < levels - 1;
  l.value = raw;
  if (!(l.value > 0.0)) l.value = 0.0;  // magnification, zero footprint, NaN
  if (l.value > levels - 1) l.value = levels - 1;
  return l;
}

}  // namespace texture_taps

double texture_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height, int levels,
                   double bias, LodRule rule) {
  return compute_lod(du_dx, dv_dx, du_dy, dv_dy, width, height, levels, bias, rule).value;
}

template <class T>
void texture_forward(const TextureParams<T>& p, T* out, T* uv_jacobian) {
  check_params(p, "texture");
  const std::int64_t C = p.channels;
  const std::int64_t base_texels = base_texel_count(p);
  // A NaN texel would turn every sample whose footprint touches it (and, through
  // the mip pyramid, whole regions of coarser levels) into NaN.
  detail::check_finite(p.tex, base_texels * C, "tex", "texture");
  detail::check_finite(p.uv, 2 * p.num_samples, "uv", "texture");
  if (mipmapped(p.filter)) {
    detail::check_finite(p.uv_dx, 2 * p.num_samples, "uv_dx", "texture");
    detail::check_finite(p.uv_dy, 2 * p.num_samples, "uv_dy", "texture");
    if (p.mip_level_bias) detail::check_finite(p.mip_level_bias, p.num_samples, "mip_level_bias", "texture");
  }
  if (uv_jacobian && p.filter != Filter::Bilinear)
    throw ValueError("texture: the uv Jacobian is saved for the bilinear filter only");
  if (uv_jacobian) {
    bilinear_forward_with_jacobian(p, out, uv_jacobian);
    return;
  }
  parallel_for(0, p.num_samples, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t s = lo; s < hi; ++s) {
      const Taps t = sample_taps<T, false>(p, s);
      T* o = out + s * C;
      // out = sum_t w_t texel_t (channel-outer: the taps' pointers stay in registers).
      const T* tx[kMaxTaps];
      for (int k = 0; k < t.n; ++k) tx[k] = texel(p, t.index[k], base_texels);
      for (std::int64_t c = 0; c < C; ++c) {
        double a = 0.0;
        for (int k = 0; k < t.n; ++k) a += t.w[k] * tx[k][c];
        o[c] = static_cast<T>(a);
      }
    }
  });
}

#define GR_INSTANTIATE(T) template void texture_forward<T>(const TextureParams<T>&, T*, T*);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
