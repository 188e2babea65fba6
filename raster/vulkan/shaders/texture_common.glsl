// Shared by the texture sampling shaders (the 2D lookups' texture_taps.glsl
// and the cube maps' cube_taps.glsl): the push constants, the input buffers,
// the LOD's log2 and clamping, and the taps every lookup is reduced to.
// Everything repeats the CPU kernels (raster/texture.cpp, raster/cube_texture.cpp)
// expression for expression in double, so that the samples are the CPU's (bit
// for bit where no LOD is involved; the LOD's log2 is within an ulp of the
// C library's, exact at powers of two).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int num_samples;
  int channels;
  int levels;    // levels of the layout (1: the texture alone; a cube map: of each face)
  int filter_mode;    // raster::Filter: 0 nearest, 1 bilinear, 2 trilinear, 3 linear-mipmap-nearest
  int wrap;      // raster::Wrap: 0 repeat, 1 clamp, 2 mirror, 3 zero (not read for a cube map)
  int flags;     // kVDown | kMajorAxis | kHasBias | kLodGrads | kTexelGrads | kHasDerivatives
  int pass;      // texture_backward: 0 per-sample gradients and magnitudes, 1 sums
  int contributions;  // texture_backward: contributions per texel value at most (fixed_point_shift)
} P;
// kHasDerivatives: a cube map's dir_da is given (without it the LOD is the bias).
const int kVDown = 1, kMajorAxis = 2, kHasBias = 4, kLodGrads = 8, kTexelGrads = 16, kHasDerivatives = 32;
const int kNearest = 0, kBilinear = 1, kTrilinear = 2, kLinearMipmapNearest = 3;
const int kRepeat = 0, kClamp = 1, kMirror = 2, kZero = 3;

// Every level's texels (level l from level_of[l].z; a cube map: face f's levels
// from f x its levels' texels), C floats each.
layout(std430, binding = 0) readonly buffer TexBuf { float texels[]; };
// Per level: (height, width, offset in texels, 0).
layout(std430, binding = 1) readonly buffer LevelBuf { ivec4 level_of[]; };
// uv (2 per sample), or a cube map's directions (3); uv_dx, uv_dy (2 each), or a
// cube map's dir_da (6, in uv_dx).
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

// The LOD from the squared footprint rho2 (texels^2) and the bias:
// raw = 0.5 log2(rho2) + bias, clamped to [0, levels - 1]; free: the clamp is
// not active. log2(0) = -inf and NaN give 0, +inf the last level (as the C
// library's log2 and the comparisons do on the CPU).
void clamp_lod(double rho2, double lod_bias, out double value, out bool free) {
  double last = double(P.levels - 1);
  bool nan = !(rho2 == rho2);
  if (nan || rho2 <= 0.0) {
    value = 0.0;
    free = false;
  } else if (!finite_bits(rho2)) {
    value = last;
    free = false;
  } else {
    precise double raw = 0.5 * log2_positive(rho2) + lod_bias;
    free = raw > 0.0 && raw < last;
    value = raw > 0.0 ? min(raw, last) : 0.0;
  }
}

// At most 8 taps: texel (index in the all-levels buffer), weight, and the
// weight's derivatives by u, v (a cube map: s, t on the face) and the LOD.
struct Taps {
  int n;
  int index[8];
  double w[8], dw_du[8], dw_dv[8], dw_dlod[8];
  bool lod_free;
};

double bias_of(int s) { return (P.flags & kHasBias) != 0 ? double(bias[s]) : 0.0; }
