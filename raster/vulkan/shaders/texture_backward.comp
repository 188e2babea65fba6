#version 460
// Per sample with a non-zero incoming gradient g: the adjoint of
// texture_forward (formulas in raster/texture.h). Pass 0 writes the sample's
// own gradients (du, dv; for trilinear through the LOD: d uv_dx, d uv_dy,
// d bias) and notes the largest texel contribution; pass 1 adds every
// contribution w_t g to its texel value in fixed point (fixed_point.glsl), so
// the sums do not depend on the order of arrival.
#include "dispatch.glsl"
#include "texture_common.glsl"
#include "fixed_point.glsl"

layout(std430, binding = 6) readonly buffer GradOutBuf { float grad_out[]; };
// Fixed-point sums: every level's texel values (level l from level_of[l].z * C).
layout(std430, binding = 7) buffer SumBuf { int64_t sums[]; };
// Per sample: du, dv, d(du/dx), d(dv/dx), d(du/dy), d(dv/dy), d bias.
layout(std430, binding = 9) writeonly buffer SampleGradBuf { float sample_grads[]; };

// g . texel over the channels, in double in channel order (dot_channels).
double dot_texel(int s, int index) {
  int C = P.channels;
  precise double d = 0.0;
  for (int c = 0; c < C; ++c) d += double(grad_out[s * C + c]) * double(texels[index * C + c]);
  return d;
}

// The sample's gradients by uv and, through the LOD, by uv_dx, uv_dy and the bias.
void sample_gradients(int s, Taps t) {
  double g[7] = double[7](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  if (P.filter_mode != kNearest) {
    precise double gu = 0.0, gv = 0.0;
    for (int k = 0; k < t.n; ++k) {
      double d = dot_texel(s, t.index[k]);
      gu += t.dw_du[k] * d;
      gv += t.dw_dv[k] * d;
    }
    g[0] = gu, g[1] = gv;
  }
  if (P.filter_mode == kTrilinear && (P.flags & kLodGrads) != 0 && t.lod_free) {
    precise double g_lod = 0.0;
    for (int k = 0; k < t.n; ++k) g_lod += t.dw_dlod[k] * dot_texel(s, t.index[k]);
    g[6] = g_lod;
    Lod l = compute_lod(s, 0.0);
    ivec4 base = level_of[0];
    double W = double(base.y), H = double(base.x);
    // k = dL/dlod / (rho2 ln 2); dA/d(du/dx) = 2 a_x W, dC/d(du/dx) = b_x W, ...
    precise double den = l.rho2 * kLn2;
    double k = div_rn(g_lod, den);
    if (l.pA != 0.0 || l.pC != 0.0) {
      precise double x0 = k * (l.pA * l.ax + 0.5 * l.pC * l.bx) * W;
      precise double x1 = k * (l.pA * l.ay + 0.5 * l.pC * l.by) * H;
      g[2] = x0, g[3] = x1;
    }
    if (l.pB != 0.0 || l.pC != 0.0) {
      precise double y0 = k * (l.pB * l.bx + 0.5 * l.pC * l.ax) * W;
      precise double y1 = k * (l.pB * l.by + 0.5 * l.pC * l.ay) * H;
      g[4] = y0, g[5] = y1;
    }
  }
  for (int i = 0; i < 7; ++i) sample_grads[7 * s + i] = float(g[i]);
}

void lookup(int s, int shift) {
  int C = P.channels;
  bool live = false;
  for (int c = 0; c < C && !live; ++c) live = grad_out[s * C + c] != 0.0;
  if (!live) {
    if (P.pass == 0)
      for (int i = 0; i < 7; ++i) sample_grads[7 * s + i] = 0.0;
    return;
  }
  Taps t = sample_taps(s, true);
  if (P.pass == 0) sample_gradients(s, t);
  if ((P.flags & kTexelGrads) == 0) return;
  // dL/d texel_t += w_t g, with w_t rounded to float as the CPU files it.
  for (int k = 0; k < t.n; ++k) {
    double w = double(float(t.w[k]));
    for (int c = 0; c < C; ++c) {
      precise double x = w * double(grad_out[s * C + c]);
      if (P.pass == 0)
        note_magnitude(0, x);
      else if (x != 0.0)
        atomicAdd(sums[t.index[k] * C + c], to_fixed(x, shift));
    }
  }
}

void main() {
  int s = linear_id();
  if (s < P.num_samples) lookup(s, P.pass == 0 ? 0 : fixed_point_shift(0, P.contributions));
  if (P.pass == 0) publish_magnitudes();
}
