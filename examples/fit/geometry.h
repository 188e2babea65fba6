// The fit example's mesh type, which keeps the positions being fitted (one
// row per distinct point) apart from the vertices the rasterizer sees (split
// where the texture coordinates jump), and its Laplacian smoothness penalty.
// Vertex normals and the Laplacian itself are the library's (ops/mesh.h).
#pragma once

#include <cstdint>

#include "autodiff/base/tensor.h"
#include "ops/render/antialias.h"
#include "ops/mesh.h"
#include "raster/mesh.h"

namespace fit {

using gr::Tensor;

// The fit's smoothness penalty: mean over points of |L p_i|^2, L the uniform
// Laplacian (gr::MeshLaplacian; its sign does not matter here).
Tensor laplacian_penalty(const gr::MeshLaplacian& laplacian, const Tensor& positions);
// d(weight * laplacian_penalty(laplacian, positions))/d positions, on a tape
// of its own (the caller's tape records nothing).
Tensor penalty_gradient(const gr::MeshLaplacian& laplacian, const Tensor& positions, double weight);

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
