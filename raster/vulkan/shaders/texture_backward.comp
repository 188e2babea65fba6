#version 460
// The adjoint of 2D texture lookups (texture_backward.glsl over
// texture_taps.glsl; formulas in raster/texture.h): the sample's gradients
// by uv and, for trilinear through the LOD, by uv_dx, uv_dy and the bias.
#include "dispatch.glsl"
#include "texture_common.glsl"
#include "texture_taps.glsl"
#include "texture_backward.glsl"

// The float32 CPU kernel files its tap weights as float.
double filed_weight(double w) { return double(float(w)); }

// The sample's gradients by uv and, through the LOD, by uv_dx, uv_dy and the bias.
void sample_gradients(int s, Taps t) {
  double g[kSampleGrads] = double[kSampleGrads](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
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
  for (int i = 0; i < kSampleGrads; ++i) sample_grads[kSampleGrads * s + i] = float(g[i]);
}
