// Shared by the texture sampling shaders: the CPU kernel's taps
// (raster/texture.cpp: compute_lod, address, bilinear_taps, sample_taps),
// expression for expression in double, so that the samples are the CPU's (bit
// for bit where no LOD is involved; the LOD's log2 is within an ulp of the
// C library's, exact at powers of two).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int num_samples;
  int channels;
  int levels;    // levels of the layout (1: the texture alone)
  int filter_mode;    // raster::Filter: 0 nearest, 1 bilinear, 2 trilinear, 3 linear-mipmap-nearest
  int wrap;      // raster::Wrap: 0 repeat, 1 clamp, 2 mirror, 3 zero
  int flags;     // kVDown | kMajorAxis | kHasBias | kLodGrads | kTexelGrads
  int pass;      // texture_backward: 0 per-sample gradients and magnitudes, 1 sums
  int contributions;  // texture_backward: contributions per texel value at most (fixed_point_shift)
} P;
const int kVDown = 1, kMajorAxis = 2, kHasBias = 4, kLodGrads = 8, kTexelGrads = 16;
const int kNearest = 0, kBilinear = 1, kTrilinear = 2, kLinearMipmapNearest = 3;
const int kRepeat = 0, kClamp = 1, kMirror = 2, kZero = 3;

// Every level's texels (level l from level_of[l].z), C floats each.
layout(std430, binding = 0) readonly buffer TexBuf { float texels[]; };
// Per level: (height, width, offset in texels, 0).
layout(std430, binding = 1) readonly buffer LevelBuf { ivec4 level_of[]; };
layout(std430, binding = 2) readonly buffer UvBuf { float uv[]; };
layout(std430, binding = 3) readonly buffer UvDxBuf { float uv_dx[]; };
layout(std430, binding = 4) readonly buffer UvDyBuf { float uv_dy[]; };
layout(std430, binding = 5) readonly buffer BiasBuf { float bias[]; };

#include "exact_math.glsl"

const double kLn2 = 0.6931471805599453;  // std::log(2.0)

// log2(x) for a finite x > 0, within an ulp or two of the C library's and
// exact at powers of two: x = m 2^e with m in [sqrt(1/2), sqrt(2)), then
// ln m = 2 atanh(z), z = (m - 1) / (m + 1), |z| < 0.172, by its series.
double log2_positive(double x) {
  int shift = 0;
  if (x < 1e-300) {  // frexp of a subnormal is undefined in GLSL
    x *= 1.2676506002282294e30;  // 2^100
    shift = 100;
  }
  int e;
  double m = frexp(x, e);
  if (m < 0.7071067811865476) {
    m *= 2.0;
    e -= 1;
  }
  precise double z = div_rn(m - 1.0, m + 1.0);
  precise double z2 = z * z;
  precise double series = 1.0 / 27.0;
  for (int k = 12; k >= 0; --k) series = series * z2 + div_rn(1.0, double(2 * k + 1));
  precise double ln_m = 2.0 * z * series;
  precise double result = double(e - shift) + div_rn(ln_m, kLn2);
  return result;
}

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
  // raw = 0.5 log2(rho2) + bias; log2(0) = -inf and NaN give 0, +inf the last level.
  double last = double(P.levels - 1);
  bool nan = !(l.rho2 == l.rho2);
  if (nan || l.rho2 <= 0.0) {
    l.value = 0.0;
    l.free = false;
  } else if (!finite_bits(l.rho2)) {
    l.value = last;
    l.free = false;
  } else {
    precise double raw = 0.5 * log2_positive(l.rho2) + lod_bias;
    l.free = raw > 0.0 && raw < last;
    l.value = raw > 0.0 ? min(raw, last) : 0.0;
  }
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

// At most 8 taps: texel (index in the all-levels buffer), weight, and the
// weight's derivatives by u, v and the LOD.
struct Taps {
  int n;
  int index[8];
  double w[8], dw_du[8], dw_dv[8], dw_dlod[8];
  bool lod_free;
};

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

double bias_of(int s) { return (P.flags & kHasBias) != 0 ? double(bias[s]) : 0.0; }

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
