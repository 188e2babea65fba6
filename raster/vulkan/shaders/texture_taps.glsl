// The 2D lookups' taps (raster/texture.cpp and raster/detail/texture_taps.h:
// compute_lod, address, bilinear_taps, sample_taps); after texture_common.glsl.

// Per-sample gradients texture_backward writes: du, dv, d(du/dx), d(dv/dx),
// d(du/dy), d(dv/dy), d bias.
const int kSampleGrads = 7;

// The LOD and what its derivative needs (compute_lod in raster/texture.cpp).
struct Lod {
  double value;  // clamped to [0, levels - 1]
  bool free;     // 0 < unclamped < levels - 1
  double rho2, pA, pB, pC, ax, ay, bx, by;
};

Lod compute_lod(int s, double lod_bias) {
  ivec4 base = level_of[0];
  Lod l;
  precise double ax = double(uv_dx[2 * s]) * double(base.y);
  precise double ay = double(uv_dx[2 * s + 1]) * double(base.x);
  precise double bx = double(uv_dy[2 * s]) * double(base.y);
  precise double by = double(uv_dy[2 * s + 1]) * double(base.x);
  l.ax = ax, l.ay = ay, l.bx = bx, l.by = by;
  precise double A = ax * ax + ay * ay;
  precise double B = bx * bx + by * by;
  l.pA = 0.0, l.pB = 0.0, l.pC = 0.0;
  if ((P.flags & kMajorAxis) == 0) {
    bool along_x = !(A < B);
    l.rho2 = along_x ? A : B;
    if (along_x) l.pA = 1.0; else l.pB = 1.0;
  } else {
    precise double C = ax * bx + ay * by;
    precise double h = 0.5 * (A - B);
    precise double r = sqrt(h * h + C * C);
    precise double rho2 = 0.5 * (A + B) + r;
    l.rho2 = rho2;
    precise double hh = 0.5 * h;
    l.pA = r > 0.0 ? 0.5 + div_rn(hh, r) : 0.5;
    l.pB = r > 0.0 ? 0.5 - div_rn(hh, r) : 0.5;
    l.pC = r > 0.0 ? div_rn(C, r) : 0.0;
  }
  clamp_lod(l.rho2, lod_bias, l.value, l.free);
  return l;
}

// Address of integer texel index i along an axis of n texels (address in raster/texture.cpp).
int address(double i, int n, int wrap) {
  double dn = double(n);
  if (i >= 0.0 && i < dn) return int(i);
  precise double r = i;
  if (wrap == kRepeat) {
    precise double wrapped = i - dn * floor(div_rn(i, dn));
    r = i < 0.0 && i >= -dn ? i + dn : i >= dn && i < 2.0 * dn ? i - dn : wrapped;
  } else if (wrap == kMirror) {
    precise double period = 2.0 * dn;
    r = i - period * floor(div_rn(i, period));
    if (r >= dn) r = period - 1.0 - r;
  }
  if (!(r >= 0.0)) r = 0.0;
  if (r > dn - 1.0) r = dn - 1.0;
  return int(r);
}

bool inside(double i, int n) { return i >= 0.0 && i < double(n); }

// Bilinear taps of level `level` at (u, v), scaled by `scale` (bilinear_taps).
void bilinear_taps(int level, double u, double v, double scale, inout Taps t, double lod_sign) {
  ivec4 lv = level_of[level];
  int H = lv.x, W = lv.y;
  bool v_down = (P.flags & kVDown) != 0;
  precise double x = u * double(W) - 0.5;
  precise double y = (v_down ? v : 1.0 - v) * double(H) - 0.5;
  double x0 = floor(x), y0 = floor(y);
  precise double fx = x - x0;
  precise double fy = y - y0;
  int ix[2] = int[2](address(x0, W, P.wrap), address(x0 + 1.0, W, P.wrap));
  int iy[2] = int[2](address(y0, H, P.wrap), address(y0 + 1.0, H, P.wrap));
  bool zero = P.wrap == kZero;
  bool in_x[2] = bool[2](!zero || inside(x0, W), !zero || inside(x0 + 1.0, W));
  bool in_y[2] = bool[2](!zero || inside(y0, H), !zero || inside(y0 + 1.0, H));
  precise double wx[2] = double[2](1.0 - fx, fx);
  precise double wy[2] = double[2](1.0 - fy, fy);
  double dwx[2] = double[2](-double(W), double(W));
  double hy = v_down ? -double(H) : double(H);
  double dwy[2] = double[2](hy, -hy);
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      int k = t.n++;
      double s = in_x[a] && in_y[b] ? scale : 0.0;
      t.index[k] = lv.z + iy[b] * W + ix[a];
      precise double w = s * wx[a] * wy[b];
      precise double du = s * dwx[a] * wy[b];
      precise double dv = s * wx[a] * dwy[b];
      precise double dl = lod_sign * wx[a] * wy[b];
      t.w[k] = w;
      t.dw_du[k] = du;
      t.dw_dv[k] = dv;
      t.dw_dlod[k] = s == 0.0 ? 0.0 : dl;
    }
}

// Taps of sample s (sample_taps). derivatives: trilinear keeps level l0 + 1
// at f = 0 too when the LOD is free (its taps give dw/dlod).
Taps sample_taps(int s, bool derivatives) {
  Taps t;
  t.n = 0;
  t.lod_free = false;
  double u = double(uv[2 * s]), v = double(uv[2 * s + 1]);
  if (P.filter_mode == kNearest) {
    ivec4 base = level_of[0];
    bool v_down = (P.flags & kVDown) != 0;
    precise double su = u * double(base.y);
    precise double sv = (v_down ? v : 1.0 - v) * double(base.x);
    double fx = floor(su), fy = floor(sv);
    int ix = address(fx, base.y, P.wrap), iy = address(fy, base.x, P.wrap);
    t.n = 1;
    t.index[0] = iy * base.y + ix;
    t.w[0] = P.wrap != kZero || (inside(fx, base.y) && inside(fy, base.x)) ? 1.0 : 0.0;
    t.dw_du[0] = 0.0, t.dw_dv[0] = 0.0, t.dw_dlod[0] = 0.0;
  } else if (P.filter_mode == kBilinear) {
    bilinear_taps(0, u, v, 1.0, t, 0.0);
  } else if (P.filter_mode == kTrilinear) {
    Lod lod = compute_lod(s, bias_of(s));
    int L = P.levels;
    int l0 = min(int(lod.value), L - 1);
    precise double f = l0 == L - 1 ? 0.0 : lod.value - double(l0);
    bilinear_taps(l0, u, v, 1.0 - f, t, -1.0);
    if (f > 0.0 || (derivatives && lod.free)) bilinear_taps(l0 + 1, u, v, f, t, 1.0);
    t.lod_free = lod.free;
  } else {
    Lod lod = compute_lod(s, bias_of(s));
    bilinear_taps(min(int(lod.value), P.levels - 1), u, v, 1.0, t, 0.0);
  }
  return t;
}
