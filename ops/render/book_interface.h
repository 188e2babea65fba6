// The C-style interface of the book's CPU implementation (chapter 23, after
// the I/F and types of chapter 22): rasterizer_cpu_forward / _backward over
// plain arrays, as a thin adapter over rasterize() and interpolate().
//
// Conventions (chapter 23):
//  - vertices carry a model-space position and an RGB colour; triangles are
//    3 vertex indices each (counter-clockwise is front; both faces are drawn);
//  - model_view_proj_4x4 is column-major (element (row r, column c) at
//    [4 c + r], OpenGL's float[16]), clip = MVP (x, y, z, 1);
//  - the G-buffer holds per pixel tri_id (1-based: triangle k is k + 1, 0 =
//    background), the perspective-correct barycentrics u = b0, v = b1 (the
//    weights of vertices 0 and 1, GBuffer::uv), and depth z/w (z_ndc; the
//    smaller wins; raster::kBackgroundDepth on background); pixel (i, j) is
//    entry j * width + i, row j = 0 at the top, centre (i + 0.5, j + 0.5);
//  - the frame buffer holds the perspective-correct interpolated colour
//    and alpha = 1 on covered pixels, colour 0 and alpha 0 on background;
//  - the backward pass reads dL_d_frame (one FramePixel per pixel) and ADDS
//    dL/dposition and dL/dcolor into vertex_grad, which the caller zeroes.
//    These are the interior (interpolation) gradients of the book's minimal
//    implementation: coverage, hence alpha, gets none (dL/dalpha is ignored;
//    the antialias op is where silhouette gradients live).
//
// Sits in ops/ because it calls ops; nothing below ops/ includes it.
#pragma once

#include <cstdint>

namespace gr::book {

struct Vertex {
  float position[3];
  float color[3];
};

struct GeometryPixel {
  std::int32_t tri_id;
  float u, v;
  float depth;
};

struct FramePixel {
  float color[3];
  float alpha;
};

struct VertexGrad {
  float d_position[3];
  float d_color[3];
};

// geometry and frame: width * height entries each, overwritten.
void rasterizer_cpu_forward(const Vertex* vertices, int num_vertices, const std::int32_t* indices,
                            int num_triangles, const float* model_view_proj_4x4, int width, int height,
                            GeometryPixel* geometry, FramePixel* frame);

// The same scene as the forward call, its geometry (checked: a different one
// throws ValueError), dL_d_frame (width * height entries); adds into
// vertex_grad (num_vertices entries). Runs a backward pass on the calling
// thread's tape, so it throws TapeError when that tape holds a graph (which
// it would clear) or a NoGradGuard is active.
void rasterizer_cpu_backward(const Vertex* vertices, int num_vertices, const std::int32_t* indices,
                             int num_triangles, const float* model_view_proj_4x4, int width, int height,
                             const GeometryPixel* geometry, const FramePixel* dL_d_frame,
                             VertexGrad* vertex_grad);

}  // namespace gr::book
