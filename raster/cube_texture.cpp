// Cube-map sampling forward and adjoint. As in raster/texture.cpp, every filter
// is reduced to at most 8 taps (texel index in the all-levels buffer, weight,
// d weight/ds, d weight/dt, d weight/dlod): the forward sums weight * texel,
// the direction adjoint sums the weight derivatives, the texel adjoint scatters
// weight * g. A tap's index is in the all-levels buffer of the inputs: level 0
// of the 6 faces first (as `faces`), then each face's levels 1.. (as
// `pyramid`). Samples run in parallel; texel gradients are scattered in sample
// order (fixed chunks, texel bands), so they do not depend on the thread count.
#include "raster/cube_texture.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/base/parallel.h"
#include "autodiff/base/tensor.h"
#include "raster/cube_map.h"
#include "raster/detail/texel_pieces.h"
#include "raster/mesh_checks.h"  // detail::check_finite

namespace gr::raster {
namespace {

constexpr int kMaxTaps = 8;

struct Taps {
  int n = 0;
  std::int64_t index[kMaxTaps];  // in the all-levels buffer (LevelIndex)
  double w[kMaxTaps], dw_ds[kMaxTaps], dw_dt[kMaxTaps];
  double dw_dlod[kMaxTaps];  // trilinear: -bilinear weight on level l0, + on level l0 + 1
};

// The LOD and what its derivative needs.
struct Lod {
  double value = 0;            // clamped to [0, levels - 1]
  bool free = false;           // 0 < unclamped < levels - 1
  bool footprint = false;      // from dir_da (false: bias only)
  double dX[3] = {0, 0, 0}, dY[3] = {0, 0, 0};  // d(dir)/dX, d(dir)/dY
  double sX = 0, sY = 0, tX = 0, tY = 0;        // face texels per pixel step
  double A = 0, B = 0, C = 0, r = 0, M = 0;
};

// Where a level's texels lie in the all-levels buffer: texel (col, row) of
// face f at origin + f * face_stride + row * S_l + col.
struct LevelIndex {
  std::int64_t origin, face_stride;
};
inline LevelIndex level_index(const MipLayout& layout, int level) {
  const std::int64_t base = std::int64_t(layout.levels[0].width) * layout.levels[0].width;
  if (level == 0) return {0, base};
  return {6 * base + layout.levels[level].offset - base, layout.total_texels - base};
}

inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Lod compute_lod(const CubeProjection& pr, const double* da, int size, int levels, double bias) {
  Lod l;
  double raw = bias;
  if (da) {
    // dir_da = (dx/dX, dx/dY, dy/dX, dy/dY, dz/dX, dz/dY).
    for (int k = 0; k < 3; ++k) l.dX[k] = da[2 * k], l.dY[k] = da[2 * k + 1];
    // Face texels per pixel: sX = S ds/d(dir) . d(dir)/dX (quotient rule in ds).
    l.sX = size * dot3(pr.ds, l.dX), l.sY = size * dot3(pr.ds, l.dY);
    l.tX = size * dot3(pr.dt, l.dX), l.tY = size * dot3(pr.dt, l.dY);
    // Major axis of the footprint ellipse: M = (A + B)/2 + sqrt((A - B)^2/4 + C^2).
    l.A = l.sX * l.sX + l.tX * l.tX;
    l.B = l.sY * l.sY + l.tY * l.tY;
    l.C = l.sX * l.sY + l.tX * l.tY;
    l.r = std::sqrt(0.25 * (l.A - l.B) * (l.A - l.B) + l.C * l.C);
    l.M = 0.5 * (l.A + l.B) + l.r;
    l.footprint = true;
    raw += 0.5 * std::log2(l.M);  // -Inf for a zero footprint: clamped below
  }
  l.free = raw > 0.0 && raw < levels - 1;
  l.value = raw > 0.0 ? raw : 0.0;  // magnification, zero footprint
  if (l.value > levels - 1) l.value = levels - 1;
  return l;
}

// Bilinear taps of level `lv` on `face` at (s, t), scaled by the level weight
// `scale`; lod_sign: the sign of d(level weight)/d lod.
template <bool kDerivatives>
inline void bilinear_taps(const MipLevel& lv, LevelIndex at, int face, double s, double t, double scale,
                          Taps& taps, double lod_sign = 0.0) {
  // Continuous texel coordinates: x = s S_l - 0.5, y = t S_l - 0.5.
  const int n = lv.width;
  const double x = s * n - 0.5, y = t * n - 0.5;
  const double x0 = std::floor(x), y0 = std::floor(y);
  const double fx = x - x0, fy = y - y0;
  // Weights and their derivatives: dfx/ds = dfy/dt = S_l.
  const double wx[2] = {1.0 - fx, fx}, wy[2] = {1.0 - fy, fy};
  const double dw[2] = {-double(n), double(n)};
  const int first = taps.n;
  double miss_w = 0, miss_ds = 0, miss_dt = 0, miss_dlod = 0;
  bool missing = false;
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      // Off the face: the neighbour's texel (cube_texel); at a corner, none.
      const int col = int(x0) + a, row = int(y0) + b;
      const bool in = col >= 0 && col < n && row >= 0 && row < n;
      const CubeTexel tx = in ? CubeTexel{face, col, row} : cube_texel(face, col, row, n);
      const double w = scale * wx[a] * wy[b];
      const double ds = kDerivatives ? scale * dw[a] * wy[b] : 0.0;
      const double dt = kDerivatives ? scale * wx[a] * dw[b] : 0.0;
      const double dlod = kDerivatives ? lod_sign * wx[a] * wy[b] : 0.0;
      if (tx.face < 0) {
        missing = true;
        miss_w = w, miss_ds = ds, miss_dt = dt, miss_dlod = dlod;
        continue;
      }
      const int k = taps.n++;
      taps.index[k] = at.origin + tx.face * at.face_stride + std::int64_t(tx.row) * n + tx.col;
      taps.w[k] = w;
      taps.dw_ds[k] = ds;
      taps.dw_dt[k] = dt;
      taps.dw_dlod[k] = dlod;
    }
  if (!missing) return;
  // Cube corner: the missing texel is the mean of the 3 real ones, so each
  // gets a third of its weight (and of the weight's derivatives).
  for (int k = first; k < taps.n; ++k) {
    taps.w[k] += miss_w / 3.0;
    taps.dw_ds[k] += miss_ds / 3.0;
    taps.dw_dt[k] += miss_dt / 3.0;
    taps.dw_dlod[k] += miss_dlod / 3.0;
  }
}

// Taps of sample i (none for the zero direction), with its projection and LOD.
template <class T, bool kDerivatives>
inline Taps sample_taps(const CubeTextureParams<T>& p, std::int64_t i, CubeProjection& pr, Lod& lod) {
  Taps taps;
  pr = cube_project(p.dir[3 * i], p.dir[3 * i + 1], p.dir[3 * i + 2]);
  if (pr.face < 0) return taps;
  const MipLevel& base = p.layout.levels[0];
  const int L = p.layout.count();
  auto level = [&](int l) { return level_index(p.layout, l); };
  if (is_mipmapped(p.filter)) {
    double da[6];
    if (p.dir_da)
      for (int k = 0; k < 6; ++k) da[k] = p.dir_da[6 * i + k];
    lod = compute_lod(pr, p.dir_da ? da : nullptr, base.width, L,
                      p.mip_level_bias ? double(p.mip_level_bias[i]) : 0.0);
  }
  switch (p.filter) {
    case CubeFilter::Nearest: {
      // Texel containing (s S, t S), kept inside the face at s = 1 or t = 1.
      const int n = base.width;
      const int col = std::min(n - 1, int(pr.s * n)), row = std::min(n - 1, int(pr.t * n));
      taps.n = 1;
      taps.index[0] = (std::int64_t(pr.face) * n + row) * n + col;
      taps.w[0] = 1.0;
      taps.dw_ds[0] = taps.dw_dt[0] = taps.dw_dlod[0] = 0.0;
      break;
    }
    case CubeFilter::Bilinear: bilinear_taps<kDerivatives>(base, level(0), pr.face, pr.s, pr.t, 1.0, taps); break;
    case CubeFilter::LinearMipmapNearest: {
      const int l0 = std::min(static_cast<int>(lod.value), L - 1);
      bilinear_taps<kDerivatives>(p.layout.levels[l0], level(l0), pr.face, pr.s, pr.t, 1.0, taps);
      break;
    }
    case CubeFilter::Trilinear: {
      // Levels l0 = floor(lod) and l0 + 1, weights 1 - f and f. For the
      // derivatives, level l0 + 1 is kept at f = 0 too (its taps give dw/dlod).
      const int l0 = std::min(static_cast<int>(lod.value), L - 1);
      const double f = l0 == L - 1 ? 0.0 : lod.value - l0;
      bilinear_taps<kDerivatives>(p.layout.levels[l0], level(l0), pr.face, pr.s, pr.t, 1.0 - f, taps, -1.0);
      if (f > 0.0 || (kDerivatives && lod.free))
        bilinear_taps<kDerivatives>(p.layout.levels[l0 + 1], level(l0 + 1), pr.face, pr.s, pr.t, f, taps, 1.0);
      break;
    }
  }
  return taps;
}

// Texel `index` of the all-levels buffer: level 0 from faces, the rest from pyramid.
template <class T>
inline const T* texel(const CubeTextureParams<T>& p, std::int64_t index) {
  const std::int64_t faces_texels = 6 * std::int64_t(p.layout.levels[0].width) * p.layout.levels[0].width;
  return index < faces_texels ? p.faces + index * p.channels : p.pyramid + (index - faces_texels) * p.channels;
}

template <class T>
void check_params(const CubeTextureParams<T>& p, const char* op) {
  if (p.layout.count() < 1 || p.layout.levels[0].width != p.layout.levels[0].height || p.channels < 1 ||
      p.num_samples < 0)
    throw ShapeError(std::string(op) + ": empty or non-square faces, or a negative sample count");
  if (is_mipmapped(p.filter) && p.layout.count() > 1 && !p.pyramid)
    throw ValueError(std::string(op) + ": mipmapped filtering needs the per-face pyramids");
}

}  // namespace

template <class T>
void cube_mip_build(const T* faces, std::int64_t C, const MipLayout& layout, T* pyramid) {
  const std::int64_t base = std::int64_t(layout.levels[0].height) * layout.levels[0].width;
  for (std::int64_t f = 0; f < 6; ++f)
    mip_build(faces + f * base * C, C, layout, pyramid + f * (layout.total_texels - base) * C);
}

double cube_texture_lod(const double dir[3], const double* dir_da, int size, int levels, double bias) {
  const CubeProjection pr = cube_project(dir[0], dir[1], dir[2]);
  if (pr.face < 0) return 0.0;
  return compute_lod(pr, dir_da, size, levels, bias).value;
}

template <class T>
void cube_texture_forward(const CubeTextureParams<T>& p, T* out) {
  check_params(p, "cube_texture");
  const std::int64_t C = p.channels, N = p.num_samples;
  const std::int64_t S = p.layout.levels[0].width;
  detail::check_finite(p.faces, 6 * S * S * C, "tex", "cube_texture");
  detail::check_finite(p.dir, 3 * N, "dir", "cube_texture");
  if (is_mipmapped(p.filter)) {
    if (p.dir_da) detail::check_finite(p.dir_da, 6 * N, "dir_da", "cube_texture");
    if (p.mip_level_bias) detail::check_finite(p.mip_level_bias, N, "mip_level_bias", "cube_texture");
  }
  parallel_for(0, N, 4096, [&](std::int64_t lo, std::int64_t hi) {
    for (std::int64_t i = lo; i < hi; ++i) {
      CubeProjection pr;
      Lod lod;
      const Taps t = sample_taps<T, false>(p, i, pr, lod);
      // out = sum_t w_t texel_t (0 for the zero direction: no taps).
      const T* tx[kMaxTaps];
      for (int k = 0; k < t.n; ++k) tx[k] = texel(p, t.index[k]);
      T* o = out + i * C;
      for (std::int64_t c = 0; c < C; ++c) {
        double a = 0.0;
        for (int k = 0; k < t.n; ++k) a += t.w[k] * tx[k][c];
        o[c] = static_cast<T>(a);
      }
    }
  });
}

namespace {

// Direction and dir_da gradients of one sample through the LOD (trilinear,
// footprint mode), given dL/dlod: see cube_texture.h.
void lod_backward(const CubeProjection& pr, const Lod& l, double g_lod, int size, double g_dir[3], double g_da[6]) {
  // dM/d(sX, sY, tX, tY); at r = 0 (isotropic) the sqrt term's slope is dropped.
  const double k = g_lod / (2.0 * l.M * std::log(2.0));
  const double ab = l.r > 0.0 ? 0.5 * (l.A - l.B) / l.r : 0.0, c = l.r > 0.0 ? l.C / l.r : 0.0;
  const double gsX = k * (l.sX * (1.0 + ab) + l.sY * c), gsY = k * (l.sY * (1.0 - ab) + l.sX * c);
  const double gtX = k * (l.tX * (1.0 + ab) + l.tY * c), gtY = k * (l.tY * (1.0 - ab) + l.tX * c);
  // sX = S ds/d(dir) . dX: to dX through ds/d(dir), to dir through d^2 s/d(dir)^2.
  double vs[3], vt[3];
  for (int j = 0; j < 3; ++j) {
    g_da[2 * j] = size * (gsX * pr.ds[j] + gtX * pr.dt[j]);
    g_da[2 * j + 1] = size * (gsY * pr.ds[j] + gtY * pr.dt[j]);
    vs[j] = gsX * l.dX[j] + gsY * l.dY[j];
    vt[j] = gtX * l.dX[j] + gtY * l.dY[j];
  }
  double hs[3], ht[3], unused[3];
  cube_project_hessian_times(pr, vs, hs, unused);
  cube_project_hessian_times(pr, vt, unused, ht);
  for (int j = 0; j < 3; ++j) g_dir[j] += size * (hs[j] + ht[j]);
}

inline bool all_finite(const double* v, int n) {
  for (int k = 0; k < n; ++k)
    if (!std::isfinite(v[k])) return false;
  return true;
}

// Where the texel gradients are summed, in double, each total rounded once
// into grad_faces. Without mip levels and in double: straight into grad_faces.
// Otherwise levels 1.. of every face in one buffer (face f's at
// f (total - base) C, summed as the taps come), and level 0 (3/4 of all
// texels) either in a buffer of its own or, where that would be the larger,
// listed by piece (raster/detail/texel_pieces.h) and summed a piece at a time
// once level 1's sums are final. Then level 1's share is added
// (mip_backward_base). Every texel takes its terms in the order one buffer of
// all levels gave them: the same bits, and a 6 x 1024 x 1024 RGB cube map
// with mips maps 48 MiB of sums, not 192.
template <class T>
struct CubeTexelSums {
  const CubeTextureParams<T>& p;
  T* grad_faces;
  std::int64_t C, base, total, faces_texels;  // faces_texels: level 0 of the 6 faces
  detail::Bands bands;                        // for the scatter, over all 6 total texels
  bool direct = false;
  bool listed = false;  // level 0 listed by piece (else summed in base_sums)
  Tensor upper_scratch, base_scratch;
  double* upper = nullptr;      // levels 1.. of every face, when there are some
  double* base_sums = nullptr;  // level 0 of the 6 faces, when not listed
  detail::BaseTapPieces<double> pieces;

  CubeTexelSums(const CubeTextureParams<T>& params, T* grad) : p(params), grad_faces(grad), C(params.channels) {
    base = std::int64_t(p.layout.levels[0].width) * p.layout.levels[0].width;
    total = p.layout.total_texels;
    faces_texels = 6 * base;
    bands = detail::texel_bands(6 * total, std::max(1, num_threads()));
    if (!grad_faces) return;
    if constexpr (std::is_same_v<T, double>) direct = total == base;
    if (direct) return;
    if (total > base) {
      upper_scratch = Tensor::zeros({6 * (total - base) * C}, DType::Float64);
      upper = upper_scratch.data<double>();
    }
    // Lists where they stay smaller than level 0's sums: at most 4 level-0
    // taps a sample (bilinear on level 0; 1 for nearest), 16 bytes each.
    const std::int64_t taps = (p.filter == CubeFilter::Nearest ? 1 : 4) * p.num_samples;
    listed = taps * std::int64_t(sizeof(detail::BaseTap<double>)) < faces_texels * C * std::int64_t(sizeof(double)) &&
             p.num_samples <= std::int64_t(UINT32_MAX);
    if (listed) {
      pieces.reset(faces_texels, bands.shift);
    } else {
      base_scratch = Tensor::zeros({faces_texels * C}, DType::Float64);
      base_sums = base_scratch.data<double>();
    }
  }

  // dL/d texel_t += w g of sample i (from the task of t's band, in sample order).
  void add(std::int64_t t, double w, std::int64_t i, const T* g) {
    if (listed && t < faces_texels) return pieces.add(t, w, i);
    auto sum = [&](auto* a) {
      for (std::int64_t c = 0; c < C; ++c) a[c] += w * g[c];
    };
    if (t >= faces_texels)
      sum(upper + (t - faces_texels) * C);
    else if (direct)
      sum(grad_faces + t * C);
    else
      sum(base_sums + t * C);
  }

  // Levels L-1 .. 1 down to level 1, face by face; then level 0 in parts
  // (pieces, or ranges of its buffer), level 1's share added, into grad_faces.
  void finish(const T* grad_out) {
    if (!grad_faces || direct) return;
    if (upper)
      for (std::int64_t f = 0; f < 6; ++f) mip_backward_levels(C, p.layout, upper + f * (total - base) * C);
    auto hand_on = [&](std::int64_t first, std::int64_t last, const double* b) { finish_level0(first, last, b); };
    if (listed)
      pieces.sum_pieces(C, grad_out, hand_on);
    else
      parallel_for(0, faces_texels, std::int64_t(1) << detail::kPieceShift,
                   [&](std::int64_t lo, std::int64_t hi) { hand_on(lo, hi, base_sums + lo * C); });
  }

  // Level 0's texels [first, last) (sums b, [last - first] x C), which may span
  // faces: level 1's share added, each total rounded once into grad_faces.
  void finish_level0(std::int64_t first, std::int64_t last, const double* b) {
    for (std::int64_t x = first; x < last;) {
      const std::int64_t f = x / base, end = std::min(last, (f + 1) * base);
      const double* bx = b + (x - first) * C;
      if (upper)
        mip_backward_base(C, p.layout, upper + f * (total - base) * C, x - f * base, end - f * base, bx,
                          grad_faces + f * base * C);
      else
        for (std::int64_t k = 0; k < (end - x) * C; ++k) grad_faces[x * C + k] += static_cast<T>(bx[k]);
      x = end;
    }
  }
};

}  // namespace

template <class T>
void cube_texture_backward(const CubeTextureParams<T>& p, const T* grad_out, const CubeTextureGrads<T>& grads) {
  check_params(p, "cube_texture backward");
  const bool trilinear = p.filter == CubeFilter::Trilinear;
  T* grad_faces = grads.faces;
  T* grad_dir = p.filter == CubeFilter::Nearest ? nullptr : grads.dir;  // nearest: piecewise constant
  T* grad_da = trilinear && p.dir_da ? grads.dir_da : nullptr;
  T* grad_bias = trilinear ? grads.mip_level_bias : nullptr;
  // The LOD carries gradients to dir only in footprint mode.
  const bool lod_grads = grad_da || grad_bias || (trilinear && p.dir_da && grad_dir);
  if (!grad_faces && !grad_dir && !lod_grads) return;
  const std::int64_t C = p.channels, N = p.num_samples;
  const int S = p.layout.levels[0].width;
  CubeTexelSums<T> sums(p, grad_faces);

  // Samples in chunks: taps, direction and LOD gradients in parallel, texel
  // sums in sample order.
  constexpr std::int64_t kChunk = 16384;
  const int stride = p.filter == CubeFilter::Nearest ? 1 : trilinear ? kMaxTaps : 4;
  const std::size_t chunk = static_cast<std::size_t>(std::min(N, kChunk));
  std::vector<std::int64_t> tap_index(grad_faces ? stride * chunk : 0);
  std::vector<double> tap_w(grad_faces ? stride * chunk : 0);
  std::vector<std::uint8_t> tap_n(chunk);  // 0: sample skipped
  const detail::Bands bands = sums.bands;
  const std::int64_t acc_texels = 6 * p.layout.total_texels;
  for (std::int64_t c0 = 0; c0 < N; c0 += kChunk) {
    const std::int64_t c1 = std::min(N, c0 + kChunk);
    parallel_for(c0, c1, 1024, [&](std::int64_t lo, std::int64_t hi) {
      for (std::int64_t i = lo; i < hi; ++i) {
        const std::int64_t j = i - c0;
        const T* g = grad_out + i * C;
        tap_n[j] = 0;
        bool any = false;
        for (std::int64_t c = 0; c < C && !any; ++c) any = g[c] != T(0);
        if (!any) continue;
        CubeProjection pr;
        Lod lod;
        const Taps t = sample_taps<T, true>(p, i, pr, lod);
        if (t.n == 0) continue;  // the zero direction
        if (grad_dir || lod_grads) {
          // dL/ds = g . sum_t (dw_t/ds) texel_t, likewise t and lod.
          double gs = 0.0, gt = 0.0, g_lod = 0.0;
          for (int k = 0; k < t.n; ++k) {
            const T* tx = texel(p, t.index[k]);
            double d = 0.0;
            for (std::int64_t c = 0; c < C; ++c) d += static_cast<double>(g[c]) * tx[c];
            gs += t.dw_ds[k] * d;
            gt += t.dw_dt[k] * d;
            g_lod += t.dw_dlod[k] * d;
          }
          // dL/d(dir) = dL/ds ds/d(dir) + dL/dt dt/d(dir), plus the LOD's share.
          double g_dir[3], g_da[6] = {0, 0, 0, 0, 0, 0};
          for (int k = 0; k < 3; ++k) g_dir[k] = gs * pr.ds[k] + gt * pr.dt[k];
          const bool lod_path = trilinear && lod.free;
          if (lod_path && grad_bias) grad_bias[i] += static_cast<T>(g_lod);
          if (lod_path && lod.footprint) lod_backward(pr, lod, g_lod, S, g_dir, g_da);
          if (grad_dir && all_finite(g_dir, 3))
            for (int k = 0; k < 3; ++k) grad_dir[3 * i + k] += static_cast<T>(g_dir[k]);
          if (grad_da && lod_path && all_finite(g_da, 6))
            for (int k = 0; k < 6; ++k) grad_da[6 * i + k] += static_cast<T>(g_da[k]);
        }
        tap_n[j] = static_cast<std::uint8_t>(t.n);
        if (!grad_faces) continue;
        for (int k = 0; k < t.n; ++k) {
          tap_index[stride * j + k] = t.index[k];
          tap_w[stride * j + k] = t.w[k];
        }
      }
    });
    if (!grad_faces) continue;
    // Scatter in sample order, dL/d texel_t += w_t g: one task per texel band,
    // each walking all taps in sample order (the same adds for any thread count).
    // A piece of level 0 lies in one band (BaseTapPieces), so one task lists it.
    parallel_for(0, bands.count, 1, [&](std::int64_t b0, std::int64_t b1) {
      const std::int64_t lo = b0 << bands.shift, hi = std::min(acc_texels, b1 << bands.shift);
      for (std::int64_t i = c0; i < c1; ++i) {
        const std::int64_t j = i - c0;
        const T* g = grad_out + i * C;
        for (int k = 0; k < tap_n[j]; ++k) {
          const std::int64_t t = tap_index[stride * j + k];
          if (t >= lo && t < hi) sums.add(t, tap_w[stride * j + k], i, g);
        }
      }
    });
  }
  sums.finish(grad_out);
}

#define GR_INSTANTIATE(T)                                                                                     \
  template void cube_mip_build<T>(const T*, std::int64_t, const MipLayout&, T*);                             \
  template void cube_texture_forward<T>(const CubeTextureParams<T>&, T*);                                    \
  template void cube_texture_backward<T>(const CubeTextureParams<T>&, const T*, const CubeTextureGrads<T>&);
GR_INSTANTIATE(float)
GR_INSTANTIATE(double)
#undef GR_INSTANTIATE

}  // namespace gr::raster
