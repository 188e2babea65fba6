#include "ops/render/book_interface.h"

#include <cmath>
#include <string>
#include <vector>

#include "autodiff/base/error.h"
#include "autodiff/tape.h"
#include "ops/render/interpolate.h"
#include "ops/tensor/linalg.h"
#include "ops/render/rasterize.h"

namespace gr::book {
namespace {

// The book's arrays as float32 tensors: positions [N, 3], colours [N, 3],
// triangles [M, 3] int32, MVP [4, 4] row-major.
struct Scene {
  Tensor positions, colors, triangles, mvp;
  int width, height;
};

void require(bool ok, const char* fn, const std::string& problem) {
  if (!ok) throw ValueError(std::string(fn) + ": " + problem);
}

Scene to_scene(const char* fn, const Vertex* vertices, int num_vertices, const std::int32_t* indices,
               int num_triangles, const float* mvp, int width, int height) {
  require(num_vertices >= 0, fn, "num_vertices must be >= 0, got " + std::to_string(num_vertices));
  require(num_triangles >= 0, fn, "num_triangles must be >= 0, got " + std::to_string(num_triangles));
  require(vertices != nullptr || num_vertices == 0, fn, "vertices is null");
  require(indices != nullptr || num_triangles == 0, fn, "indices is null");
  require(mvp != nullptr, fn, "model_view_proj_4x4 is null");
  std::vector<float> positions(3 * static_cast<std::size_t>(num_vertices));
  std::vector<float> colors(positions.size());
  for (int k = 0; k < num_vertices; ++k)
    for (int c = 0; c < 3; ++c) {
      positions[3 * k + c] = vertices[k].position[c];
      colors[3 * k + c] = vertices[k].color[c];
    }
  for (float x : colors) require(std::isfinite(x), fn, "a vertex colour is not finite");
  std::vector<float> rows(16);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) rows[4 * r + c] = mvp[4 * c + r];  // column-major in, row-major out
  for (float x : rows) require(std::isfinite(x), fn, "model_view_proj_4x4 has a non-finite entry");
  return {Tensor::from_vector(positions, {num_vertices, 3}), Tensor::from_vector(colors, {num_vertices, 3}),
          Tensor::from_vector(std::vector<std::int32_t>(indices, indices + 3 * std::size_t(num_triangles)),
                              {num_triangles, 3}),
          Tensor::from_vector(rows, {4, 4}), width, height};
}

struct Rendered {
  GBuffer gbuffer;
  Tensor color;  // [H, W, 3]
};

// rasterize + perspective-correct interpolation, recorded when the scene's
// positions or colours require a gradient.
Rendered render(const Scene& s) {
  const Tensor clip = transform_points(s.positions, s.mvp);
  GBuffer g = rasterize(clip, s.triangles, {s.width, s.height});
  Tensor color = interpolate(s.colors, g, s.triangles);
  return {std::move(g), std::move(color)};
}

}  // namespace

void rasterizer_cpu_forward(const Vertex* vertices, int num_vertices, const std::int32_t* indices,
                            int num_triangles, const float* model_view_proj_4x4, int width, int height,
                            GeometryPixel* geometry, FramePixel* frame) {
  const char* fn = "rasterizer_cpu_forward";
  const Scene scene = to_scene(fn, vertices, num_vertices, indices, num_triangles, model_view_proj_4x4, width, height);
  NoGradGuard no_grad;
  const Rendered r = render(scene);
  require(geometry != nullptr && frame != nullptr, fn, "geometry and frame must not be null");
  const auto* tri = r.gbuffer.tri_id.data<std::int32_t>();
  const float* uv = r.gbuffer.uv.data<float>();
  const float* depth = r.gbuffer.depth.data<float>();
  const float* color = r.color.data<float>();
  for (std::int64_t p = 0; p < std::int64_t(width) * height; ++p) {
    geometry[p] = {tri[p], uv[2 * p], uv[2 * p + 1], depth[p]};
    frame[p] = {{color[3 * p], color[3 * p + 1], color[3 * p + 2]}, tri[p] != 0 ? 1.0f : 0.0f};
  }
}

void rasterizer_cpu_backward(const Vertex* vertices, int num_vertices, const std::int32_t* indices,
                             int num_triangles, const float* model_view_proj_4x4, int width, int height,
                             const GeometryPixel* geometry, const FramePixel* dL_d_frame,
                             VertexGrad* vertex_grad) {
  const char* fn = "rasterizer_cpu_backward";
  Scene scene = to_scene(fn, vertices, num_vertices, indices, num_triangles, model_view_proj_4x4, width, height);
  require(geometry != nullptr && dL_d_frame != nullptr, fn, "geometry and dL_d_frame must not be null");
  require(vertex_grad != nullptr || num_vertices == 0, fn, "vertex_grad is null");
  // It records on, sweeps and so empties the calling thread's tape.
  if (!grad_mode_enabled())
    throw TapeError(std::string(fn) + ": gradient recording is off (a NoGradGuard is active)");
  if (Tape::current().size() != 0)
    throw TapeError(std::string(fn) + ": the thread's tape holds a recorded graph, which this call would clear; "
                    "run it before recording or after backward()");
  scene.positions.set_requires_grad();
  scene.colors.set_requires_grad();
  const Rendered r = render(scene);

  // The adjoint is taken at the G-buffer recomputed here; it must be the caller's.
  const auto* tri = r.gbuffer.tri_id.data<std::int32_t>();
  const float* uv = r.gbuffer.uv.data<float>();
  const float* depth = r.gbuffer.depth.data<float>();
  const std::int64_t pixels = std::int64_t(width) * height;
  std::vector<float> upstream(3 * pixels);
  for (std::int64_t p = 0; p < pixels; ++p) {
    const GeometryPixel& g = geometry[p];
    for (int c = 0; c < 3; ++c) upstream[3 * p + c] = dL_d_frame[p].color[c];
    const bool same = g.tri_id == tri[p] && g.u == uv[2 * p] && g.v == uv[2 * p + 1] && g.depth == depth[p];
    const bool finite = std::isfinite(upstream[3 * p]) && std::isfinite(upstream[3 * p + 1]) &&
                        std::isfinite(upstream[3 * p + 2]);
    if (!same || !finite) {
      Tape::current().clear();  // only this call's nodes are on it
      require(same, fn, "geometry differs from what rasterizer_cpu_forward gives for these vertices, indices and "
                        "MVP (first at pixel " + std::to_string(p) + ")");
      require(finite, fn, "dL_d_frame has a non-finite colour gradient at pixel " + std::to_string(p));
    }
  }

  backward(r.color, Tensor::from_vector(upstream, {height, width, 3}));
  if (num_vertices == 0) return;
  const Tensor d_position = scene.positions.grad();
  const Tensor d_color = scene.colors.grad();
  for (int k = 0; k < num_vertices; ++k)
    for (int c = 0; c < 3; ++c) {
      if (d_position.defined()) vertex_grad[k].d_position[c] += d_position.data<float>()[3 * k + c];
      if (d_color.defined()) vertex_grad[k].d_color[c] += d_color.data<float>()[3 * k + c];
    }
}

}  // namespace gr::book
