// Cube-map sampling and its adjoint on plain arrays (no tape): a texture of 6
// square faces (6 x S x S x C, faces +X, -X, +Y, -Y, +Z, -Z) looked up by a 3D
// direction per sample, with nearest, bilinear and mipmapped filters.
//
// Conventions (docs/cube_maps.md; face selection in raster/cube_map.h):
// - A direction (need not be normalised) selects a face and (s, t) in [0, 1]^2;
//   on a level of S_l x S_l texels, x = s S_l - 0.5, y = t S_l - 0.5 are the
//   continuous texel coordinates (texel (col, row) centred at x = col, y = row).
// - Nearest: texel (floor(s S), floor(t S)) of level 0, clamped into the face.
// - Bilinear: the 4 texels around (x, y) on level 0. Taps off the face are read
//   from the neighbouring face (cube_texel), so filtering is seamless; at a
//   cube corner, where only 3 texels meet, the missing 4th tap reads the mean
//   of the other 3 (nvdiffrast's rule): each real tap's weight becomes
//   w + w_missing / 3.
// - Mipmapped (per-face box pyramids, raster/mipmap.h, down to 1 x 1 or to
//   max_mip_level): LOD from the direction's screen derivatives dir_da =
//   (dx/dX, dx/dY, dy/dX, dy/dY, dz/dX, dz/dY) (nvdiffrast's cube uv_da),
//   mapped to face texels by the quotient rule, sX = S ds/d(dir) . d(dir)/dX
//   (likewise sY, tX, tY), then the footprint's major axis:
//     A = sX^2 + tX^2, B = sY^2 + tY^2, C = sX sY + tX tY,
//     lod = 0.5 log2((A + B)/2 + sqrt((A - B)^2/4 + C^2)) + bias,
//   clamped to [0, L - 1]. Without dir_da (bias only): lod = bias.
//   LinearMipmapNearest: bilinear on level floor(lod) (nvdiffrast; GL rounds).
//   Trilinear: (1 - f) bilinear(l0) + f bilinear(l0 + 1), l0 = floor(lod),
//   f = lod - l0.
// - The zero direction has no face: its output is 0 and it gets no gradient.
#pragma once

#include <cstdint>

#include "raster/mipmap.h"

namespace gr::raster {

enum class CubeFilter { Nearest, Bilinear, LinearMipmapNearest, Trilinear };

inline bool is_mipmapped(CubeFilter f) { return f == CubeFilter::LinearMipmapNearest || f == CubeFilter::Trilinear; }

// Inputs of one cube-map call, shared by the forward and the adjoint.
template <class T>
struct CubeTextureParams {
  const T* faces = nullptr;    // level 0: 6 x S x S x channels
  const T* pyramid = nullptr;  // levels 1.. of every face (cube_mip_build); mipmapped filters with L > 1
  MipLayout layout;            // levels of ONE face (S x S, ...); non-mipmapped filters: level 0 only
  std::int64_t channels = 0;
  const T* dir = nullptr;             // num_samples x 3
  const T* dir_da = nullptr;          // num_samples x 6, mipmapped only; null: the LOD is the bias alone
  const T* mip_level_bias = nullptr;  // num_samples, added to the LOD (mipmapped only; optional)
  std::int64_t num_samples = 0;
  CubeFilter filter = CubeFilter::Bilinear;
};

// Where cube_texture_backward writes (each may be null; all ACCUMULATED, +=).
template <class T>
struct CubeTextureGrads {
  T* faces = nullptr;           // 6 x S x S x channels
  T* dir = nullptr;             // num_samples x 3 (not for Nearest)
  T* dir_da = nullptr;          // num_samples x 6 (Trilinear)
  T* mip_level_bias = nullptr;  // num_samples (Trilinear)
};

// The per-face pyramids: levels 1.. of face f (layout.total_texels - S*S
// texels of C channels) at pyramid + f (layout.total_texels - S*S) C, each
// level the box average of the one above (mip_build).
template <class T>
void cube_mip_build(const T* faces, std::int64_t channels, const MipLayout& layout, T* pyramid);

// The LOD of one sample (clamped to [0, levels - 1]) for faces of size S;
// dir_da null: bias alone. The zero direction gives 0.
double cube_texture_lod(const double dir[3], const double* dir_da, int size, int levels, double bias = 0.0);

// out: num_samples x channels. Throws ValueError naming the element if the
// faces, dir, dir_da or mip_level_bias hold NaN or Inf.
template <class T>
void cube_texture_forward(const CubeTextureParams<T>& p, T* out);

// Adjoint of cube_texture_forward, ACCUMULATED (+=). With g = dL/d(out) of a
// sample and its taps t (texel t, weight w_t, corner rule and trilinear level
// weights included):
//   dL/d(texel t of level l) += w_t g, then per face through the box-filter
//   adjoint (mip_backward) to level 0;
//   dL/ds = g . sum_t (dw_t/ds) texel_t (dx/ds = S_l), likewise t, and
//   dL/d(dir) = dL/ds ds/d(dir) + dL/dt dt/d(dir) (quotient rule, cube_map.h).
// Nearest has no gradient to dir (piecewise constant); LinearMipmapNearest none
// through the LOD. Trilinear, where the LOD is not clamped (0 < lod < L - 1;
// the right derivative at an integer LOD): dL/dlod = g . (B_l0+1 - B_l0),
// dL/dbias = dL/dlod, and with M = (A + B)/2 + r, r = sqrt((A - B)^2/4 + C^2),
// k = dL/dlod / (2 M ln 2):
//   G_sX = k (sX (1 + (A - B)/(2r)) + sY C / r),  G_sY = k (sY (1 - (A - B)/(2r)) + sX C / r),
//   G_tX, G_tY likewise with t (r = 0, an isotropic footprint: the terms in 1/r are dropped);
//   dL/d(d dir/dX) = S (G_sX ds/d(dir) + G_tX dt/d(dir)), likewise dY;
//   dL/d(dir) += S (H_s (G_sX dX + G_sY dY) + H_t (G_tX dX + G_tY dY)),
//   H_s, H_t = the second derivatives of s, t w.r.t. dir.
// Non-finite direction gradients of a sample (a direction so short that
// 1 / |ma|^3 overflows) are written as 0. Texel sums are accumulated in
// double and added in sample order: bit-identical for any thread count.
// Samples with an all-zero incoming gradient are skipped.
template <class T>
void cube_texture_backward(const CubeTextureParams<T>& p, const T* grad_out, const CubeTextureGrads<T>& grads);

}  // namespace gr::raster
