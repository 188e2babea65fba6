// Shared by the interpolate shaders: the linear blend of vertex attributes
// with the G-buffer's perspective-correct barycentrics
// (raster/barycentric_interpolate.cpp), expression for expression in double:
//   A = b0 A_0 + b1 A_1 + (1 - b0 - b1) A_2,
//   dA/dx = db0/dx A_0 + db1/dx A_1 + (-db0/dx - db1/dx) A_2  (likewise y).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant) uniform Params {
  int width;
  int height;
  int num_vertices;
  int num_tris;
  int channels;
  int pass;      // interpolate_backward: 0 = largest magnitudes, 1 = sums
  int num_diff;  // channels differentiated (attribute derivatives; needs rast_db)
  int count;     // interpolate_backward: contributions per element at most
} P;

layout(std430, binding = 0) readonly buffer AttrBuf { float attr[]; };
layout(std430, binding = 1) readonly buffer TriBuf { int tris[]; };
layout(std430, binding = 2) readonly buffer TriIdBuf { int tri_id[]; };
layout(std430, binding = 3) readonly buffer RastBuf { float rast[]; };
layout(std430, binding = 4) readonly buffer DbBuf { float db[]; };
layout(std430, binding = 5) readonly buffer DiffBuf { int diff[]; };

#include "exact_math.glsl"

ivec3 tri_of(int t) { return ivec3(tris[3 * t], tris[3 * t + 1], tris[3 * t + 2]); }

// The three vertices' weights at pixel p and, with derivatives, their x and y
// derivatives (pixel_weights).
struct Weights {
  double w[3];
  double dx[3];
  double dy[3];
};

Weights pixel_weights(int p) {
  Weights k;
  k.w[0] = double(rast[4 * p]);
  k.w[1] = double(rast[4 * p + 1]);
  precise double w2 = (1.0 - k.w[0]) - k.w[1];
  k.w[2] = w2;
  for (int i = 0; i < 3; ++i) k.dx[i] = k.dy[i] = 0.0;
  if (P.num_diff > 0) {
    k.dx[0] = double(db[4 * p]);
    k.dy[0] = double(db[4 * p + 1]);
    k.dx[1] = double(db[4 * p + 2]);
    k.dy[1] = double(db[4 * p + 3]);
    precise double dx2 = -k.dx[0] - k.dx[1];
    precise double dy2 = -k.dy[0] - k.dy[1];
    k.dx[2] = dx2;
    k.dy[2] = dy2;
  }
  return k;
}

// sum_k f_k A_k for channel ch of vertices tri, in the CPU's order.
double blend(double f[3], ivec3 tri, int ch) {
  int C = P.channels;
  precise double a = (f[0] * double(attr[tri.x * C + ch]) + f[1] * double(attr[tri.y * C + ch])) +
                     f[2] * double(attr[tri.z * C + ch]);
  return a;
}
