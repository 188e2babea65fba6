// Shared by the G-buffer shaders: nvdiffrast's layout from the coverage
// (raster/barycentric_gbuffer.cpp), expression for expression in double (the
// rules of exact_math.glsl), so the values are the CPU kernel's bits.
// With V_k the homogeneous screen vertices, c_k = V_k+1 x V_k+2, C = sum c_k,
// D = V_0 . c_0 per triangle; a_k = e . c_k, S = sum a_k per pixel centre e.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int width;
  int height;
  int num_vertices;
  int num_tris;
  int pass;   // gbuffer_backward: 0 = largest magnitudes, 1 = sums
  int y_up;   // row 0 is the bottom row (the coverage was rasterized with y negated)
  int flags;  // gbuffer: bit 0 write db; gbuffer_backward: kDeviceRast.. (below)
  int count;  // gbuffer_backward: contributions per element at most (fixed_point_shift)
} P;

layout(std430, binding = 0) readonly buffer ClipBuf { float clip[]; };
layout(std430, binding = 1) readonly buffer TriBuf { int tris[]; };

#include "exact_math.glsl"
#include "clip_of.glsl"

ivec3 tri_of(int t) { return ivec3(tris[3 * t], tris[3 * t + 1], tris[3 * t + 2]); }

// One triangle's terms (triangle_terms).
struct Terms {
  dvec3 V[3];
  dvec3 c[3];
  dvec3 C;
  double D;
  double z[3];
};

Terms triangle_terms(ivec3 tri) {
  Terms t;
  int id[3] = int[3](tri.x, tri.y, tri.z);
  for (int k = 0; k < 3; ++k) {
    t.V[k] = homogeneous(id[k]);
    t.z[k] = double(clip[4 * id[k] + 2]);
  }
  t.C = dvec3(0.0);
  for (int k = 0; k < 3; ++k) {
    t.c[k] = hcross(t.V[(k + 1) % 3], t.V[(k + 2) % 3]);
    precise dvec3 C = t.C + t.c[k];
    t.C = C;
  }
  t.D = hdot(t.V[0], t.c[0]);
  return t;
}

// The pixel centre of pixel p.
dvec3 centre_of(int p) { return dvec3(double(p % P.width) + 0.5, double(p / P.width) + 0.5, 1.0); }

// a_k = e . c_k and S = sum a_k (pixel_terms); false unless S and D are
// nonzero and finite.
bool pixel_terms(Terms t, int p, out double a[3], out double S) {
  dvec3 e = centre_of(p);
  S = 0.0;
  for (int k = 0; k < 3; ++k) {
    a[k] = hdot(e, t.c[k]);
    precise double s = S + a[k];
    S = s;
  }
  return S != 0.0 && t.D != 0.0 && finite_bits(S) && finite_bits(t.D);
}

// z/w before the clamp: sum_k a_k z_k / D. The CPU's sum starts at +0.0, so
// a zero sum is +0 and the quotient takes D's sign; that zero is made on the
// bits (a compiler may drop a "0.0 +" and keep a -0 sum). D is finite, non-zero.
double depth_of(Terms t, double a[3]) {
  precise double zw = (a[0] * t.z[0] + a[1] * t.z[1]) + a[2] * t.z[2];
  if (zw == 0.0) return packDouble2x32(uvec2(0u, unpackDouble2x32(t.D).y & 0x80000000u));
  return div_rn(zw, t.D);
}
