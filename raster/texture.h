// Texture sampling and its adjoint on plain arrays (no tape): nearest,
// bilinear and mipmapped trilinear lookups of an H x W x C texture at
// per-sample (u, v), with repeat / clamp / mirror addressing.
//
// Conventions (docs/texture.md):
// - u to the right, v UP (OBJ / OpenGL); texel row 0 is the TOP row of the
//   texture (as read_image returns it). Continuous texel coordinates of a
//   level of size H_l x W_l are x = u W_l - 0.5, y = (1 - v) H_l - 0.5, so
//   texel (i, j) (column, row) has its centre at x = i, y = j, and (u, v) =
//   (0, 1) is the top-left corner of the image.
// - Addressing acts on integer texel indices: Repeat i mod n, Clamp
//   min(max(i, 0), n - 1), Mirror reflects with period 2n (0..n-1, n-1..0),
//   Zero reads every texel outside the texture as 0 (nvdiffrast's 'zero'):
//   a bilinear lookup near the border blends towards 0, and one entirely
//   outside returns 0 with zero gradients.
//   Bilinear lookups blend the two texels on either side of a repeat seam.
// - Nearest picks texel (floor(u W), floor((1 - v) H)) of level 0.
//   Bilinear blends the 4 texels around (x, y) on level 0.
//   Trilinear: LOD = log2(max(|(du/dx W, dv/dx H)|, |(du/dy W, dv/dy H)|))
//   (W, H of level 0; isotropic, as OpenGL), clamped to [0, L - 1];
//   out = (1 - f) bilinear(level floor(lod)) + f bilinear(level floor(lod) + 1),
//   f = lod - floor(lod). Levels come from raster/mipmap.h.
#pragma once

#include <cstdint>

#include "raster/mipmap.h"

namespace gr::raster {

// Trilinear blends the two mip levels around the LOD; LinearMipmapNearest
// (nvdiffrast's 'linear-mipmap-nearest') filters bilinearly on level
// floor(LOD) alone (no gradient to the LOD: it is piecewise constant in it).
enum class Filter { Nearest, Bilinear, Trilinear, LinearMipmapNearest };
// Filters that read the mip levels (and need uv_dx, uv_dy).
constexpr bool mipmapped(Filter f) { return f == Filter::Trilinear || f == Filter::LinearMipmapNearest; }
// How the footprint sets the LOD, with a = (du/dx W, dv/dx H), b = (du/dy W,
// dv/dy H) in level-0 texels: Isotropic (OpenGL): rho^2 = max(|a|^2, |b|^2);
// MajorAxis (nvdiffrast): rho^2 = the squared major axis of the footprint
// ellipse, (A + B)/2 + sqrt((A - B)^2/4 + C^2) with A = |a|^2, B = |b|^2,
// C = a.b. lod = 0.5 log2(rho^2) + bias.
enum class LodRule { Isotropic, MajorAxis };
enum class Wrap { Repeat, Clamp, Mirror, Zero };

// Inputs of one texture call, shared by the forward and the adjoint.
template <class T>
struct TextureParams {
  const T* tex = nullptr;      // level 0: layout.levels[0].height x width x channels
  const T* pyramid = nullptr;  // levels 1.. (mip_build), needed when layout has more than one level
  // True when the levels 1.. are the user's own (a mip stack), not built from
  // tex: their gradients then stay on their level instead of flowing to tex.
  bool user_pyramid = false;
  MipLayout layout;            // trilinear: the levels to use; otherwise only level 0 is read
  std::int64_t channels = 0;
  const T* uv = nullptr;       // num_samples x 2
  const T* uv_dx = nullptr;    // num_samples x 2: d(u, v)/dx per pixel (trilinear only)
  const T* uv_dy = nullptr;    // num_samples x 2: d(u, v)/dy per pixel (trilinear only)
  const T* mip_level_bias = nullptr;  // num_samples, added to the LOD (trilinear only; optional)
  std::int64_t num_samples = 0;
  Filter filter = Filter::Bilinear;
  Wrap wrap = Wrap::Repeat;
  // nvdiffrast's row convention: texel rows run with v (y = v H_l - 0.5, row 0
  // at v = 0, dy/dv = +H_l) instead of against it.
  bool v_down = false;
  LodRule lod_rule = LodRule::Isotropic;
};

// Level of detail of one sample for a texture of base size width x height with
// `levels` mip levels: log2 of the larger screen-space footprint in texels,
// plus `bias`, clamped to [0, levels - 1] (NaN and -Inf give 0).
double texture_lod(double du_dx, double dv_dx, double du_dy, double dv_dy, int width, int height,
                   int levels, double bias = 0.0, LodRule rule = LodRule::Isotropic);

// Where texture_backward writes (each may be null; all ACCUMULATED, +=).
template <class T>
struct TextureGrads {
  T* tex = nullptr;             // level-0 shape
  T* uv = nullptr;              // num_samples x 2
  T* uv_dx = nullptr;           // num_samples x 2 (trilinear)
  T* uv_dy = nullptr;           // num_samples x 2 (trilinear)
  T* mip_level_bias = nullptr;  // num_samples (trilinear)
  T* pyramid = nullptr;         // levels 1.. as in TextureParams::pyramid (user_pyramid only)
};

// out: num_samples x channels. Throws ValueError naming the element if the
// texture, uv (or, for trilinear, uv_dx / uv_dy) holds NaN or Inf.
// uv_jacobian (bilinear only; optional): also writes, per sample, d out/du (C
// values) then d out/dv (C values), num_samples x 2 x channels, for the
// adjoint: from the texels the lookup loads anyway, so the adjoint need not
// read the texture again for the uv gradient.
template <class T>
void texture_forward(const TextureParams<T>& p, T* out, T* uv_jacobian = nullptr);

// Adjoint of texture_forward, ACCUMULATED (+=). With g = dL/d(out) of a sample
// and the taps t (texel t, weight w_t; weights include the trilinear level
// weights 1 - f and f):
//   dL/d(texel t of level l) += w_t g, then each level's gradient flows to
//   level 0 through the box-filter adjoint (mip_backward);
//   dL/du += g . sum_t (dw_t/du) texel_t,  dw/du from dx/du = W_l,
//   dL/dv += g . sum_t (dw_t/dv) texel_t,  dw/dv from dy/dv = -H_l.
// Nearest has no gradient to uv (piecewise constant).
// Trilinear, through the level of detail (docs/texture.md): out = (1 - f) B_l0
// + f B_l0+1 with f = lod - l0, so dL/dlod = g . (B_l0+1 - B_l0) wherever lod
// is not clamped (0 < lod < levels - 1; the right derivative at integer lod),
// then dL/dbias = dL/dlod and, with lod = 0.5 log2(rho2) + bias and
// k = dL/dlod / (rho2 ln 2) (= 2 dL/drho2), through rho2(A, B, C):
//   dL/d(du/dx) = k (p_A a_x + p_C b_x / 2) W,  dL/d(dv/dx) = k (p_A a_y + p_C b_y / 2) H,
//   dL/d(du/dy) = k (p_B b_x + p_C a_x / 2) W,  dL/d(dv/dy) = k (p_B b_y + p_C a_y / 2) H,
// with the partials p of rho2: Isotropic p_A = 1, p_B = p_C = 0 when |a| >= |b|
// (else p_B = 1); MajorAxis p_A = 1/2 + (A - B) / (4 r), p_B = 1/2 - (A - B) / (4 r),
// p_C = C / r, r = sqrt((A - B)^2/4 + C^2) (r = 0: p_A = p_B = 1/2, p_C = 0).
// Texel gradients are added in sample order, so the result is bit-identical
// for any thread count; they are summed in T (float32 in float32, as the tape
// sums) when only level 0 is read, in double when mip levels are (then rounded
// once). Samples with an all-zero incoming gradient are skipped.
// uv_jacobian: the forward's (bilinear), or null to compute dL/du, dL/dv from the texels.
template <class T>
void texture_backward(const TextureParams<T>& p, const T* grad_out, const TextureGrads<T>& grads,
                      const T* uv_jacobian = nullptr);

}  // namespace gr::raster
