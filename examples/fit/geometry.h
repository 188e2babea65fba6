// Differentiable mesh quantities for the fit example, written with tensor ops
// so gradients reach the vertex positions: area-weighted vertex normals and a
// uniform Laplacian smoothness penalty. Also the example's mesh type, which
// keeps the positions being fitted (one row per distinct point) apart from
// the vertices the rasterizer sees (split where the texture coordinates jump).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "autodiff/tensor.h"
#include "ops/antialias.h"
#include "raster/mesh.h"

namespace fit {

using gr::Tensor;

// Vertex normals [N, 3] of positions [N, 3] and triangles [M, 3]: each
// triangle's cross product (length = twice its area) is added to its three
// corners with scatter_add, then normalized.
Tensor vertex_normals(const Tensor& positions, const Tensor& triangles);

// The uniform ("umbrella") Laplacian of a fixed triangle list:
// L(p)_i = p_i - (1/deg_i) sum_{j in N(i)} p_j, N(i) the edge neighbours of
// vertex i (an isolated vertex has L(p)_i = p_i). apply() is one recorded op,
// a sparse product over the neighbour lists (CSR), in parallel over rows on
// large meshes.
class UniformLaplacian {
 public:
  UniformLaplacian(const Tensor& triangles, std::int64_t num_vertices);
  // L(p) for p [N, C] float32 or float64. Each neighbour sum runs in ascending
  // neighbour order and is then scaled by 1/deg_i rounded to float32, so the
  // result is the same for any thread count.
  // dL/dp_j = g_j - sum_{i in N(j)} g_i / deg_i (L^T g: N is symmetric, the
  // weights are not).
  Tensor apply(const Tensor& positions) const;
  // mean over vertices of |L(p)_i|^2: the smoothness penalty.
  Tensor penalty(const Tensor& positions) const;

  // The neighbour lists: vertex i's neighbours, ascending, are
  // neighbours[start[i] .. start[i + 1]); inv_degree[i] = 1/deg_i (0 when isolated).
  struct Adjacency {
    std::vector<std::int64_t> start;
    std::vector<std::int32_t> neighbours;
    std::vector<float> inv_degree;
  };

 private:
  std::shared_ptr<const Adjacency> adjacency_;  // shared with recorded adjoints
  std::int64_t num_vertices_;
};

// A triangle mesh as the fit example renders and optimizes it. `positions`
// has one row per distinct point (welded), so a uv seam cannot tear open when
// the points move; the rasterizer sees `render_vertices` vertices, each one a
// row of `positions` (render_to_point) with its own uv.
struct SurfaceMesh {
  Tensor positions;        // [P, 3] float32, the welded points
  Tensor point_triangles;  // [M, 3] int32 into positions (normals, Laplacian)
  Tensor triangles;        // [M, 3] int32 into the render vertices
  Tensor render_to_point;  // [R] int32: render vertex -> row of positions
  Tensor uvs;              // [R, 2] float32 (u right, v up), or undefined
  gr::AntialiasTopology topology;  // antialias edge topology, built once

  std::int64_t num_points() const { return positions.size(0); }
  std::int64_t num_triangles() const { return triangles.size(0); }
  // Per render vertex values [R, C] of per-point values [P, C] (a gather, so gradients flow back).
  Tensor to_render(const Tensor& per_point) const;
};

// Welds the vertices of `mesh` that share a position (keeping their uvs on the
// render side) and drops triangles that collapse. Throws ValueError if none remain.
SurfaceMesh make_surface(const gr::raster::Mesh& mesh);

// An icosphere of 20 * 4^subdivisions triangles with equirectangular uvs
// computed from each point's direction (u = 0.5 + atan2(x, z) / 2pi,
// v = 0.5 + asin(y) / pi); triangles that straddle the u = 0/1 seam get copies
// of their low-u corners at u + 1, which a repeating texture wraps back.
SurfaceMesh sphere_surface(int subdivisions, double radius);

}  // namespace fit
