#version 460
// The adjoint of cube-map lookups (texture_backward.glsl over cube_taps.glsl;
// formulas in raster/cube_texture.h): the sample's gradients by its direction
// and, for trilinear through the LOD where it is free, by dir_da and the bias.
#include "dispatch.glsl"
#include "texture_common.glsl"
#include "cube_taps.glsl"
#include "texture_backward.glsl"

// The CPU kernel keeps its tap weights in double.
double filed_weight(double w) { return w; }

// g_dir += the LOD's share, g_da = dL/d(dir_da), given dL/dlod (lod_backward).
void lod_backward(Projection pr, Lod l, double g_lod, inout double g_dir[3], out double g_da[6]) {
  precise double den = 2.0 * l.M * kLn2;
  double k = div_rn(g_lod, den);
  // dM/d(sX, sY, tX, tY); at r = 0 (isotropic) the sqrt term's slope is dropped.
  double ab = l.r > 0.0 ? div_rn(0.5 * (l.A - l.B), l.r) : 0.0;
  double c = l.r > 0.0 ? div_rn(l.C, l.r) : 0.0;
  precise double gsX = k * (l.sX * (1.0 + ab) + l.sY * c);
  precise double gsY = k * (l.sY * (1.0 - ab) + l.sX * c);
  precise double gtX = k * (l.tX * (1.0 + ab) + l.tY * c);
  precise double gtY = k * (l.tY * (1.0 - ab) + l.tX * c);
  double size = double(level_of[0].y);
  double vs[3], vt[3];
  for (int j = 0; j < 3; ++j) {
    precise double daX = size * (gsX * pr.ds[j] + gtX * pr.dt[j]);
    precise double daY = size * (gsY * pr.ds[j] + gtY * pr.dt[j]);
    precise double s = gsX * l.dX[j] + gsY * l.dY[j];
    precise double t = gtX * l.dX[j] + gtY * l.dY[j];
    g_da[2 * j] = daX, g_da[2 * j + 1] = daY, vs[j] = s, vt[j] = t;
  }
  double hs[3], ht[3];
  hessian_times(pr, vs, vt, hs, ht);
  for (int j = 0; j < 3; ++j) {
    precise double x = g_dir[j] + size * (hs[j] + ht[j]);
    g_dir[j] = x;
  }
}

// d dir (0..2), d dir_da (3..8), d bias (9). Nearest: none (piecewise
// constant); a direction or dir_da gradient that is not finite: 0.
void sample_gradients(int s, Taps t) {
  double g[kSampleGrads] = double[kSampleGrads](0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  Projection pr = cube_project(s);
  if (pr.face >= 0 && P.filter_mode != kNearest) {
    // dL/ds = g . sum_t (dw_t/ds) texel_t, likewise t and the LOD.
    precise double gs = 0.0, gt = 0.0, g_lod = 0.0;
    for (int k = 0; k < t.n; ++k) {
      double d = dot_texel(s, t.index[k]);
      gs += t.dw_du[k] * d;
      gt += t.dw_dv[k] * d;
      g_lod += t.dw_dlod[k] * d;
    }
    double g_dir[3], g_da[6] = double[6](0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for (int k = 0; k < 3; ++k) {
      precise double x = gs * pr.ds[k] + gt * pr.dt[k];
      g_dir[k] = x;
    }
    bool lod_path = P.filter_mode == kTrilinear && t.lod_free;
    if (lod_path) {
      g[9] = g_lod;
      Lod l = compute_lod(s, pr);
      if (l.footprint) lod_backward(pr, l, g_lod, g_dir, g_da);
    }
    bool dir_finite = true, da_finite = true;
    for (int k = 0; k < 3; ++k) dir_finite = dir_finite && finite_bits(g_dir[k]);
    for (int k = 0; k < 6; ++k) da_finite = da_finite && finite_bits(g_da[k]);
    for (int k = 0; k < 3 && dir_finite; ++k) g[k] = g_dir[k];
    for (int k = 0; k < 6 && lod_path && da_finite; ++k) g[3 + k] = g_da[k];
  }
  for (int i = 0; i < kSampleGrads; ++i) sample_grads[kSampleGrads * s + i] = float(g[i]);
}
