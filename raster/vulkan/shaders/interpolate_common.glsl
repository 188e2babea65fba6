// Shared by the interpolate shaders: the CPU kernel's per-pixel weights
// (raster/interpolate.cpp, pixel_weights), expression for expression in double.
//   perspective: q_k = lambda_k / w_k (clipped triangles: q_k = F_k / D from the
//                clip positions and the pixel centre), weight_k = q_k / sum q;
//   linear:      weight_k = lambda_k;  lambda = (1 - u - v, u, v).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int width;
  int height;
  int num_vertices;
  int num_tris;
  int channels;
  int pass;         // interpolate_backward: 0 = largest magnitudes, 1 = sums
  int perspective;  // 1: perspective-correct weights; 0: screen-space (linear)
  int y_up;         // the G-buffer was rasterized with y negated (row 0 at the bottom)
} P;

layout(std430, binding = 0) readonly buffer ClipBuf { float clip[]; };
layout(std430, binding = 1) readonly buffer TriBuf { int tris[]; };
layout(std430, binding = 2) readonly buffer AttrBuf { float attr[]; };
layout(std430, binding = 3) readonly buffer TriIdBuf { int tri_id[]; };
layout(std430, binding = 4) readonly buffer UvBuf { float uv[]; };

#include "exact_math.glsl"
#include "clip_of.glsl"

// Behind the near plane for the weights (kMinFrontW in raster/interpolate.cpp).
bool behind_near_plane(dvec4 c) { return !(c.w > 1e-14 && c.z >= -c.w); }

// One covered pixel's weights and what the adjoint needs of them.
struct Weights {
  double lambda[3];
  double weight[3];
  double q[3];
  double inv_s;
  double inv_w[3];  // perspective, not from_clip
  bool from_clip;
  dvec3 V[3];       // from_clip: homogeneous screen vertices
  double inv_d;     // from_clip: 1 / D
  dvec3 e;          // from_clip: the pixel centre (x + 0.5, y + 0.5, 1)
};

Weights pixel_weights(ivec3 tri, int p) {
  Weights pw;
  double u = double(uv[2 * p]), v = double(uv[2 * p + 1]);
  precise double l0 = 1.0 - u - v;
  pw.lambda[0] = l0;
  pw.lambda[1] = u;
  pw.lambda[2] = v;
  pw.from_clip = false;
  pw.inv_s = 0.0;
  for (int k = 0; k < 3; ++k) {
    pw.weight[k] = pw.lambda[k];
    pw.q[k] = 0.0;
    pw.inv_w[k] = 0.0;
    pw.V[k] = dvec3(0.0);
  }
  pw.inv_d = 0.0;
  pw.e = dvec3(0.0);
  if (P.perspective == 0) return pw;
  dvec4 c[3] = dvec4[3](clip_of(tri.x), clip_of(tri.y), clip_of(tri.z));
  if (behind_near_plane(c[0]) || behind_near_plane(c[1]) || behind_near_plane(c[2])) {
    // q_k = F_k / D, F_k = e . (V_k+1 x V_k+2), D = V_0 . (V_1 x V_2).
    pw.from_clip = true;
    pw.V[0] = homogeneous(tri.x);
    pw.V[1] = homogeneous(tri.y);
    pw.V[2] = homogeneous(tri.z);
    pw.inv_d = safe_inv(hdot(pw.V[0], hcross(pw.V[1], pw.V[2])));
    pw.e = dvec3(double(p % P.width) + 0.5, double(p / P.width) + 0.5, 1.0);
    for (int k = 0; k < 3; ++k) {
      precise double qk = hdot(pw.e, hcross(pw.V[(k + 1) % 3], pw.V[(k + 2) % 3])) * pw.inv_d;
      pw.q[k] = qk;
    }
  } else {
    for (int k = 0; k < 3; ++k) {
      pw.inv_w[k] = safe_inv(c[k].w);
      precise double qk = pw.lambda[k] * pw.inv_w[k];
      pw.q[k] = qk;
    }
  }
  // s = ((0 + q0) + q1) + q2, weight_k = q_k / s (weights_from).
  precise double s = ((0.0 + pw.q[0]) + pw.q[1]) + pw.q[2];
  pw.inv_s = safe_inv(s);
  for (int k = 0; k < 3; ++k) {
    precise double wk = pw.q[k] * pw.inv_s;
    pw.weight[k] = wk;
  }
  return pw;
}

ivec3 tri_of(int t) { return ivec3(tris[3 * t], tris[3 * t + 1], tris[3 * t + 2]); }

// A = sum_k weight_k A_k for channel ch of vertices tri.
double blend(Weights pw, ivec3 tri, int ch) {
  int C = P.channels;
  precise double a = (pw.weight[0] * double(attr[tri.x * C + ch]) + pw.weight[1] * double(attr[tri.y * C + ch])) +
                     pw.weight[2] * double(attr[tri.z * C + ch]);
  return a;
}
